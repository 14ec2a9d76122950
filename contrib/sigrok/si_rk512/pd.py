##
## This file is part of the si project (SIMATIC ET 200S serial interface protocols).
## SPDX-License-Identifier: MIT OR Apache-2.0
##
## The telegram headers: [CP 341] §2.2.3, Table 2-1 (command telegram, 10 bytes;
## a continuation telegram has bytes 1 to 4 only) and Table 2-2 (reaction
## telegram, 4 bytes, byte 4 the error number).

import sigrokdecode as srd

RX, TX = 0, 1
COMMANDS = {0x41: 'SEND', 0x4F: 'SEND DX', 0x45: 'FETCH'}
AREAS = {0x44: 'DB', 0x58: 'DX', 0x45: 'I', 0x41: 'Q', 0x4D: 'M', 0x54: 'T', 0x5A: 'C'}

class Decoder(srd.Decoder):
    api_version = 3
    id = 'si_rk512'
    name = 'RK 512'
    longname = 'Siemens RK 512 computer link'
    desc = 'Siemens RK 512 SEND/FETCH telegrams in 3964(R) blocks.'
    license = 'mit'
    inputs = ['si_3964r']
    outputs = []
    tags = ['Embedded/industrial']
    annotations = (
        ('rx-telegram', 'RX telegram'),
        ('tx-telegram', 'TX telegram'),
        ('error', 'Error'),
    )
    annotation_rows = (
        ('rx-telegrams', 'RX telegrams', (0,)),
        ('tx-telegrams', 'TX telegrams', (1,)),
        ('errors', 'Errors', (2,)),
    )

    def __init__(self):
        self.reset()

    def reset(self):
        pass

    def start(self):
        self.out_ann = self.register(srd.OUTPUT_ANN)

    def describe(self, d):
        '''The telegram's meaning, or None if the block is no RK 512 telegram.'''
        if len(d) < 4 or d[0] not in (0x00, 0xFF) or d[1] != 0x00:
            return None
        cont = d[0] == 0xFF
        if d[2] == 0x00:
            name = 'continuation reaction' if cont else 'reaction'
            return '%s, error %02XH, %d B data' % (name, d[3], len(d) - 4)
        cmd = COMMANDS.get(d[2])
        if cmd is None:
            return None
        area = AREAS.get(d[3], '%02XH' % d[3])
        if cont:
            return 'continuation %s %s, %d B data' % (cmd, area, len(d) - 4)
        if len(d) < 10:
            return None
        length = d[6] << 8 | d[7]
        flag = 'no flag' if d[8] == 0xFF else 'flag M%d.%d' % (d[8], d[9] & 0x0F)
        cpu = d[9] >> 4
        return '%s %s%d from DW%d, length %d, %s, CPU %s, %d B data' % (
            cmd, area, d[4], d[5], length, flag, '-' if cpu == 0xF else cpu, len(d) - 10)

    def decode(self, ss, es, data):
        ptype, rxtx, pdata = data
        if ptype != 'BLOCK':
            return
        block, bcc_ok = pdata
        text = self.describe(block)
        cls = 0 if rxtx == RX else 1
        if text is None:
            self.put(ss, es, self.out_ann, [2, ['block is no RK 512 telegram', 'not RK 512']])
            return
        if not bcc_ok:
            text += ' (BCC error)'
        self.put(ss, es, self.out_ann, [cls, [text]])
