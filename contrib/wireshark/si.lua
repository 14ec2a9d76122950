-- Wireshark dissectors for the serial protocols of the SIMATIC ET 200S serial interface
-- modules, as `si` captures them (`si trace export --pcap`, `si monitor --pcap`):
--
--   si_3964r   3964(R) control characters and blocks (DLE doubling, DLE ETX, BCC)
--   si_rk512   RK 512 telegrams in 3964(R) blocks (command and reaction headers)
--   si_uss     USS telegrams (STX, LGE, ADR, PKW/PZD net data, BCC)
--   si_dpcoord the DP window protocol's windows (coordination byte, data)
--
-- Each is registered by name, so a capture of exported PDUs (LINKTYPE_WIRESHARK_UPPER_PDU)
-- naming it in its tag 12 is decoded with no configuration, and into "rtacser.data" for
-- Decode As on RTAC serial captures.
--
-- Use:  wireshark -X lua_script:contrib/wireshark/si.lua capture.pcapng
--       tshark -X lua_script:contrib/wireshark/si.lua -r capture.pcapng -V
-- or copy the file into Wireshark's personal plugins folder.
--
-- The value tables between the GENERATED markers come from the Rust decoders:
-- `si trace lua-tables` prints them, and a test fails when this file and the decoders differ.

-- BEGIN GENERATED TABLES (si trace lua-tables)
local rk512_commands = {
    [0x41] = "Send",
    [0x45] = "Fetch",
    [0x4F] = "SendDx",
}
local rk512_data_types = {
    [0x41] = "Outputs",
    [0x43] = "Counters",
    [0x44] = "Db",
    [0x45] = "Inputs",
    [0x4D] = "Flags",
    [0x54] = "Timers",
    [0x58] = "Dx",
    [0x5A] = "Counters",
}
local uss_pkw_errors = {
    [0] = "illegal parameter number",
    [1] = "parameter value cannot be changed (read-only)",
    [2] = "lower or upper value limit exceeded",
    [3] = "wrong sub-index",
    [4] = "no array",
    [5] = "wrong data type",
    [6] = "setting not allowed (can only be reset)",
    [7] = "descriptive element cannot be changed",
    [9] = "description data not available",
    [10] = "access group wrong",
    [11] = "no parameter change rights",
    [12] = "wrong password",
    [17] = "task cannot be executed in this operating state",
    [18] = "other error",
    [20] = "illegal value",
    [101] = "parameter number deactivated",
}
local dpcoord_jobs = {
    [0] = "Idle",
    [1] = "Send",
    [2] = "Receive",
    [3] = "ReadV24",
    [4] = "WriteV24",
    [5] = "Parameters",
    [6] = "Reserved",
    [7] = "EndOfJob",
}
-- END GENERATED TABLES

local STX, ETX, DLE, NAK = 0x02, 0x03, 0x10, 0x15

------------------------------------------------------------------------------------------
-- 3964(R)
------------------------------------------------------------------------------------------
local p3964 = Proto("si_3964r", "3964(R) procedure")
local controls = { [STX] = "STX", [DLE] = "DLE", [NAK] = "NAK" }
local f3 = {
    control = ProtoField.uint8("si_3964r.control", "Control character", base.HEX, controls),
    data = ProtoField.bytes("si_3964r.data", "User data"),
    length = ProtoField.uint16("si_3964r.length", "User data length", base.DEC),
    bcc = ProtoField.uint8("si_3964r.bcc", "Block check character (BCC)", base.HEX),
    bcc_ok = ProtoField.bool("si_3964r.bcc_ok", "BCC correct"),
}
p3964.fields = { f3.control, f3.data, f3.length, f3.bcc, f3.bcc_ok }
local e3 = {
    bcc = ProtoExpert.new("si_3964r.bcc_error", "BCC error", expert.group.CHECKSUM, expert.severity.ERROR),
    nak = ProtoExpert.new("si_3964r.nak", "NAK: block rejected", expert.group.RESPONSE_CODE, expert.severity.WARN),
    retry = ProtoExpert.new("si_3964r.retry", "Retry: STX after the partner's NAK", expert.group.SEQUENCE, expert.severity.NOTE),
    unended = ProtoExpert.new("si_3964r.no_etx", "Block without DLE ETX", expert.group.MALFORMED, expert.severity.ERROR),
}
p3964.experts = { e3.bcc, e3.nak, e3.retry, e3.unended }
p3964.prefs.bcc = Pref.bool("Block check (3964R)", true, "Blocks end with a BCC (3964(R)); off for plain 3964")

-- Per direction: did the partner NAK the last block? (first pass only, kept per frame)
local nak_pending = {}
local retry_frames = {}

-- The user data of a raw block (DLE doubling removed), whether DLE ETX ended it, its BCC.
local function unstuff(tvb)
    local data = ByteArray.new()
    local n = tvb:len()
    local i = 0
    local ended = false
    while i < n do
        local b = tvb(i, 1):uint()
        if b == DLE and i + 1 < n then
            local nb = tvb(i + 1, 1):uint()
            if nb == DLE then
                data:append(ByteArray.new("10"))
                i = i + 2
            elseif nb == ETX then
                ended = true
                i = i + 2
                break
            else
                data:append(tvb(i, 1):bytes())
                i = i + 1
            end
        else
            data:append(tvb(i, 1):bytes())
            i = i + 1
        end
    end
    return data, ended, i
end

local function direction(pinfo)
    return pinfo.p2p_dir or 0
end

-- Dissect a 3964(R) frame; returns the unstuffed user data of a block (or nil).
local function dissect_3964(tvb, pinfo, tree)
    pinfo.cols.protocol = "3964(R)"
    local t = tree:add(p3964, tvb())
    local dir = direction(pinfo)
    if tvb:len() == 1 then
        local c = tvb(0, 1):uint()
        t:add(f3.control, tvb(0, 1))
        pinfo.cols.info = controls[c] or string.format("%02XH", c)
        if c == NAK then
            t:add_proto_expert_info(e3.nak)
            if not pinfo.visited then nak_pending[1 - dir] = true end
        elseif c == STX then
            if not pinfo.visited and nak_pending[dir] then
                retry_frames[pinfo.number] = true
                nak_pending[dir] = false
            end
            if retry_frames[pinfo.number] then t:add_proto_expert_info(e3.retry) end
        end
        return nil
    end
    local data, ended, after = unstuff(tvb)
    t:add(f3.length, tvb(0, after), data:len())
    t:add(f3.data, tvb(0, after), data:raw())
    if not ended then t:add_proto_expert_info(e3.unended) end
    if p3964.prefs.bcc and after < tvb:len() then
        local bcc = 0
        for k = 0, after - 1 do bcc = bit.bxor(bcc, tvb(k, 1):uint()) end
        local found = tvb(after, 1):uint()
        t:add(f3.bcc, tvb(after, 1))
        local ok = t:add(f3.bcc_ok, tvb(after, 1), bcc == found)
        if bcc ~= found then
            ok:add_proto_expert_info(e3.bcc, string.format("BCC error: expected %02XH, found %02XH", bcc, found))
        end
    end
    pinfo.cols.info = string.format("block %d B", data:len())
    return data
end

function p3964.dissector(tvb, pinfo, tree)
    dissect_3964(tvb, pinfo, tree)
    return tvb:len()
end

------------------------------------------------------------------------------------------
-- RK 512 (in 3964(R) blocks)
------------------------------------------------------------------------------------------
local prk = Proto("si_rk512", "RK 512 computer link")
local fr = {
    telegram = ProtoField.uint8("si_rk512.telegram", "Telegram ID", base.HEX, { [0x00] = "first", [0xFF] = "continuation" }),
    command = ProtoField.uint8("si_rk512.command", "Command", base.HEX, rk512_commands),
    data_type = ProtoField.uint8("si_rk512.data_type", "Data type", base.HEX, rk512_data_types),
    db = ProtoField.uint8("si_rk512.db", "DB number", base.DEC),
    dw = ProtoField.uint8("si_rk512.dw", "Start address (DW)", base.DEC),
    length = ProtoField.uint16("si_rk512.length", "Length", base.DEC),
    coord_byte = ProtoField.uint8("si_rk512.coord_byte", "Coordination flag byte", base.DEC),
    coord_bit = ProtoField.uint8("si_rk512.coord_bit", "Coordination flag bit", base.DEC, nil, 0x0F),
    cpu = ProtoField.uint8("si_rk512.cpu", "CPU", base.DEC, nil, 0xF0),
    error = ProtoField.uint8("si_rk512.error", "Error number", base.HEX),
    reaction = ProtoField.bool("si_rk512.reaction", "Reaction telegram"),
    data = ProtoField.bytes("si_rk512.data", "Data"),
}
prk.fields = { fr.telegram, fr.command, fr.data_type, fr.db, fr.dw, fr.length, fr.coord_byte, fr.coord_bit, fr.cpu, fr.error, fr.reaction, fr.data }
local er = {
    refused = ProtoExpert.new("si_rk512.refused", "Reaction with an error number", expert.group.RESPONSE_CODE, expert.severity.WARN),
}
prk.experts = { er.refused }

function prk.dissector(tvb, pinfo, tree)
    local data = dissect_3964(tvb, pinfo, tree)
    if data == nil or data:len() < 4 then return tvb:len() end
    pinfo.cols.protocol = "RK 512"
    local tel = data:tvb("RK 512 telegram")
    local t = tree:add(prk, tel())
    t:add(fr.telegram, tel(0, 1))
    if tel(2, 1):uint() == 0 then
        t:add(fr.reaction, tel(2, 1), true)
        local e = t:add(fr.error, tel(3, 1))
        if tel(3, 1):uint() ~= 0 then e:add_proto_expert_info(er.refused) end
        if tel:len() > 4 then t:add(fr.data, tel(4)) end
        pinfo.cols.info = string.format("reaction, error %02XH", tel(3, 1):uint())
        return tvb:len()
    end
    t:add(fr.reaction, tel(2, 1), false)
    t:add(fr.command, tel(2, 1))
    t:add(fr.data_type, tel(3, 1))
    local cmd = rk512_commands[tel(2, 1):uint()] or "?"
    if tel(0, 1):uint() == 0xFF or tel:len() < 10 then
        if tel:len() > 4 then t:add(fr.data, tel(4)) end
        pinfo.cols.info = cmd .. " (continuation)"
        return tvb:len()
    end
    t:add(fr.db, tel(4, 1))
    t:add(fr.dw, tel(5, 1))
    t:add(fr.length, tel(6, 2))
    t:add(fr.coord_byte, tel(8, 1))
    t:add(fr.cpu, tel(9, 1))
    t:add(fr.coord_bit, tel(9, 1))
    if tel:len() > 10 then t:add(fr.data, tel(10)) end
    pinfo.cols.info = string.format("%s DB%d.DW%d, length %d", cmd, tel(4, 1):uint(), tel(5, 1):uint(), tel(6, 2):uint())
    return tvb:len()
end

------------------------------------------------------------------------------------------
-- USS
------------------------------------------------------------------------------------------
local puss = Proto("si_uss", "USS (universal serial interface)")
local fu = {
    stx = ProtoField.uint8("si_uss.stx", "STX", base.HEX),
    lge = ProtoField.uint8("si_uss.lge", "Telegram length LGE", base.DEC),
    adr = ProtoField.uint8("si_uss.adr", "Address byte ADR", base.HEX),
    address = ProtoField.uint8("si_uss.adr.address", "Slave address", base.DEC, nil, 0x1F),
    broadcast = ProtoField.bool("si_uss.adr.broadcast", "Broadcast", 8, nil, 0x20),
    mirror = ProtoField.bool("si_uss.adr.mirror", "Mirror telegram", 8, nil, 0x40),
    special = ProtoField.bool("si_uss.adr.special", "Special telegram", 8, nil, 0x80),
    net = ProtoField.bytes("si_uss.net", "Net data"),
    pke = ProtoField.uint16("si_uss.pke", "PKE", base.HEX),
    ak = ProtoField.uint16("si_uss.pke.ak", "AK (task / response ID)", base.DEC, nil, 0xF000),
    spm = ProtoField.bool("si_uss.pke.spm", "SPM", 16, nil, 0x0800),
    pnu = ProtoField.uint16("si_uss.pke.pnu", "PNU (parameter number)", base.DEC, nil, 0x07FF),
    ind = ProtoField.uint16("si_uss.ind", "IND", base.HEX),
    pwe = ProtoField.uint16("si_uss.pwe", "PWE", base.HEX),
    pzd = ProtoField.uint16("si_uss.pzd", "PZD", base.HEX),
    bcc = ProtoField.uint8("si_uss.bcc", "Block check character (BCC)", base.HEX),
    bcc_ok = ProtoField.bool("si_uss.bcc_ok", "BCC correct"),
    error = ProtoField.uint16("si_uss.pkw_error", "PKW error number", base.DEC, uss_pkw_errors),
}
puss.fields = { fu.stx, fu.lge, fu.adr, fu.address, fu.broadcast, fu.mirror, fu.special, fu.net, fu.pke, fu.ak, fu.spm, fu.pnu, fu.ind, fu.pwe, fu.pzd, fu.bcc, fu.bcc_ok, fu.error }
local eu = {
    bcc = ProtoExpert.new("si_uss.bcc_error", "BCC error", expert.group.CHECKSUM, expert.severity.ERROR),
    ak7 = ProtoExpert.new("si_uss.ak7", "Task cannot be executed (AK 7)", expert.group.RESPONSE_CODE, expert.severity.WARN),
    length = ProtoExpert.new("si_uss.lge_error", "LGE does not match the telegram", expert.group.MALFORMED, expert.severity.ERROR),
}
puss.experts = { eu.bcc, eu.ak7, eu.length }
puss.prefs.pkw = Pref.uint("PKW words", 4, "PKW words per telegram (0, 3 or 4; 4 on MICROMASTER drives)")

function puss.dissector(tvb, pinfo, tree)
    pinfo.cols.protocol = "USS"
    local t = tree:add(puss, tvb())
    local n = tvb:len()
    if n < 4 then return n end
    t:add(fu.stx, tvb(0, 1))
    t:add(fu.lge, tvb(1, 1))
    local adr = t:add(fu.adr, tvb(2, 1))
    adr:add(fu.address, tvb(2, 1))
    adr:add(fu.broadcast, tvb(2, 1))
    adr:add(fu.mirror, tvb(2, 1))
    adr:add(fu.special, tvb(2, 1))
    local lge = tvb(1, 1):uint()
    if lge + 2 ~= n then t:add_proto_expert_info(eu.length) end
    local net_len = math.max(0, math.min(lge - 2, n - 4))
    local reply = direction(pinfo) == 1
    if net_len > 0 then
        local net = t:add(fu.net, tvb(3, net_len))
        local pkw = puss.prefs.pkw
        local off = 3
        if pkw > 0 and net_len >= pkw * 2 then
            net:add(fu.pke, tvb(off, 2))
            net:add(fu.ak, tvb(off, 2))
            net:add(fu.spm, tvb(off, 2))
            net:add(fu.pnu, tvb(off, 2))
            local ak = bit.rshift(tvb(off, 2):uint(), 12)
            if pkw >= 2 then net:add(fu.ind, tvb(off + 2, 2)) end
            for k = 2, pkw - 1 do net:add(fu.pwe, tvb(off + 2 * k, 2)) end
            if reply and ak == 7 and pkw >= 3 then
                local e = net:add(fu.error, tvb(off + 4, 2))
                e:add_proto_expert_info(eu.ak7)
            end
            off = off + pkw * 2
        end
        while off + 2 <= 3 + net_len do
            net:add(fu.pzd, tvb(off, 2))
            off = off + 2
        end
    end
    local bcc = 0
    for k = 0, n - 2 do bcc = bit.bxor(bcc, tvb(k, 1):uint()) end
    t:add(fu.bcc, tvb(n - 1, 1))
    local ok = t:add(fu.bcc_ok, tvb(n - 1, 1), bcc == tvb(n - 1, 1):uint())
    if bcc ~= tvb(n - 1, 1):uint() then
        ok:add_proto_expert_info(eu.bcc, string.format("BCC error: expected %02XH, found %02XH", bcc, tvb(n - 1, 1):uint()))
    end
    pinfo.cols.info = string.format("%s %d (%d B)", reply and "answer" or "to", bit.band(tvb(2, 1):uint(), 0x1F), net_len)
    return n
end

------------------------------------------------------------------------------------------
-- DP window protocol
------------------------------------------------------------------------------------------
local pdp = Proto("si_dpcoord", "ET 200S SI DP window")
local fd = {
    coord = ProtoField.uint8("si_dpcoord.coord", "Coordination byte", base.HEX),
    job = ProtoField.uint8("si_dpcoord.job", "Job code", base.DEC, dpcoord_jobs, 0x70),
    error = ProtoField.bool("si_dpcoord.error", "Error", 8, nil, 0x08),
    exec = ProtoField.uint8("si_dpcoord.exec", "Execution number", base.DEC, nil, 0x07),
    data = ProtoField.bytes("si_dpcoord.data", "Window data"),
}
pdp.fields = { fd.coord, fd.job, fd.error, fd.exec, fd.data }
local ed = {
    error = ProtoExpert.new("si_dpcoord.error_bit", "Coordination byte with the error bit", expert.group.RESPONSE_CODE, expert.severity.WARN),
}
pdp.experts = { ed.error }

function pdp.dissector(tvb, pinfo, tree)
    pinfo.cols.protocol = "DP window"
    local t = tree:add(pdp, tvb())
    if tvb:len() < 1 then return 0 end
    local c = t:add(fd.coord, tvb(0, 1))
    c:add(fd.job, tvb(0, 1))
    local e = c:add(fd.error, tvb(0, 1))
    c:add(fd.exec, tvb(0, 1))
    local byte = tvb(0, 1):uint()
    if bit.band(byte, 0x08) ~= 0 then e:add_proto_expert_info(ed.error) end
    if tvb:len() > 1 then t:add(fd.data, tvb(1)) end
    pinfo.cols.info = string.format("%02XH %s, exec %d", byte, dpcoord_jobs[bit.band(bit.rshift(byte, 4), 7)], bit.band(byte, 7))
    return tvb:len()
end

------------------------------------------------------------------------------------------
-- Registration: a Lua Proto's dissector is registered under the Proto's name, which is what
-- the exported-PDU dissector looks up (find_dissector of tag 12); and each goes into
-- "rtacser.data" for Decode As on RTAC serial captures.
------------------------------------------------------------------------------------------
local rtac = DissectorTable.get("rtacser.data")
for _, p in ipairs({ p3964, prk, puss, pdp }) do
    if rtac ~= nil then rtac:add_for_decode_as(p) end
end
