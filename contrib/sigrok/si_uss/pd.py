##
## This file is part of the si project (SIMATIC ET 200S serial interface protocols).
## SPDX-License-Identifier: MIT OR Apache-2.0
##
## The telegram: [Modbus/USS] §3.7.1 (STX, LGE, ADR, net data in words high byte
## first, BCC; PKW then PZD); the LGE count, the ADR bits and the BCC rule from
## the USS protocol specification [USS] (LGE = net data + ADR + BCC; BCC = XOR of
## every byte before it, STX included; ADR bit 5 broadcast, bit 6 mirror, bit 7
## special); the PKE layout (AK bits 15-12, SPM bit 11, PNU bits 10-0) from [USS]
## and [MM420].

import sigrokdecode as srd

STX = 0x02
RX, TX = 0, 1
NAMES = ('RX', 'TX')

class Decoder(srd.Decoder):
    api_version = 3
    id = 'si_uss'
    name = 'USS'
    longname = 'Siemens USS'
    desc = 'Siemens universal serial interface protocol (drives): telegrams, PKW and PZD.'
    license = 'mit'
    inputs = ['uart']
    outputs = ['si_uss']
    tags = ['Embedded/industrial']
    options = (
        {'id': 'pkw', 'desc': 'PKW words (0, 3, 4)', 'default': 4, 'values': (0, 3, 4)},
        {'id': 'gap', 'desc': 'Gap in character times that abandons a telegram',
            'default': 2},
    )
    annotations = (
        ('rx-field', 'RX field'),
        ('rx-telegram', 'RX telegram'),
        ('tx-field', 'TX field'),
        ('tx-telegram', 'TX telegram'),
        ('error', 'Error'),
    )
    annotation_rows = (
        ('rx-fields', 'RX fields', (0,)),
        ('rx-telegrams', 'RX telegrams', (1,)),
        ('tx-fields', 'TX fields', (2,)),
        ('tx-telegrams', 'TX telegrams', (3,)),
        ('errors', 'Errors', (4,)),
    )

    def __init__(self):
        self.reset()

    def reset(self):
        # Per direction: the telegram so far, as (ss, es, byte) triples.
        self.tel = [[], []]
        self.charlen = None

    def start(self):
        self.out_ann = self.register(srd.OUTPUT_ANN)
        self.out_python = self.register(srd.OUTPUT_PYTHON)

    def field(self, rxtx, ss, es, texts):
        self.put(ss, es, self.out_ann, [0 if rxtx == RX else 2, texts])

    def words(self, rxtx, chars, names):
        '''Annotate 16-bit words (high byte first) with their names.'''
        for i, name in enumerate(names):
            a, b = chars[2 * i], chars[2 * i + 1]
            w = a[2] << 8 | b[2]
            if name == 'PKE':
                ak, spm, pnu = w >> 12, (w >> 11) & 1, w & 0x7FF
                self.field(rxtx, a[0], b[1],
                           ['PKE %04X: AK %d, SPM %d, PNU %d' % (w, ak, spm, pnu),
                            'AK %d PNU %d' % (ak, pnu), '%04X' % w])
            else:
                self.field(rxtx, a[0], b[1], ['%s %04X' % (name, w), '%04X' % w])

    def finish(self, rxtx):
        t = self.tel[rxtx]
        raw = [c[2] for c in t]
        ss, es = t[0][0], t[-1][1]
        bcc = 0
        for x in raw[:-1]:
            bcc ^= x
        ok = bcc == raw[-1]
        adr = raw[2]
        net = raw[3:-1]
        self.field(rxtx, t[0][0], t[0][1], ['STX', 'S'])
        self.field(rxtx, t[1][0], t[1][1], ['LGE %d' % raw[1], '%d' % raw[1]])
        kind = []
        if adr & 0x20:
            kind.append('broadcast')
        if adr & 0x40:
            kind.append('mirror')
        if adr & 0x80:
            kind.append('special')
        self.field(rxtx, t[2][0], t[2][1],
                   ['ADR %02X: slave %d%s' % (adr, adr & 0x1F,
                                              ''.join(', ' + k for k in kind)),
                    'ADR %d' % (adr & 0x1F), '%d' % (adr & 0x1F)])
        body = t[3:-1]
        pkw = self.options['pkw'] * 2
        if len(body) >= pkw and len(body) % 2 == 0:
            names = ['PKE', 'IND'] + ['PWE%d' % k for k in range(1, pkw // 2 - 1)]
            self.words(rxtx, body[:pkw], names[:pkw // 2])
            self.words(rxtx, body[pkw:],
                       ['PZD%d' % k for k in range(1, (len(body) - pkw) // 2 + 1)])
        self.field(rxtx, t[-1][0], t[-1][1],
                   ['BCC %02X %s' % (raw[-1], 'ok' if ok else 'error (expected %02X)' % bcc),
                    'BCC %s' % ('ok' if ok else 'error'), 'ok' if ok else 'err'])
        text = 'ADR %02XH, net %s' % (adr, ' '.join('%02X' % x for x in net))
        self.put(ss, es, self.out_ann, [1 if rxtx == RX else 3,
                 ['%s%s' % (text, '' if ok else ' BCC error'),
                  'ADR %d (%d B)' % (adr & 0x1F, len(net))]])
        if not ok:
            self.put(ss, es, self.out_ann, [4, ['BCC error', 'BCC']])
        self.put(ss, es, self.out_python, ['TELEGRAM', rxtx, (adr, bytes(net), ok)])
        self.tel[rxtx] = []

    def decode(self, ss, es, data):
        ptype, rxtx, pdata = data
        if ptype == 'STARTBIT' and self.charlen is None:
            # One bit of the first start bit; a USS character is 11 bits (8E1).
            self.charlen = (es - ss) * 11
        if ptype in ('PARITY ERROR', 'BREAK') or (ptype == 'FRAME' and not pdata[1]):
            self.put(ss, es, self.out_ann, [4, ['%s %s' % (NAMES[rxtx],
                     'framing error' if ptype == 'FRAME' else ptype.lower())]])
            self.tel[rxtx] = []
            return
        if ptype != 'DATA':
            return
        b = pdata[0]
        t = self.tel[rxtx]
        if t and self.charlen and ss - t[-1][1] > self.options['gap'] * self.charlen:
            self.put(t[0][0], t[-1][1], self.out_ann,
                     [4, ['telegram broken off after %d characters' % len(t), 'broken']])
            t = self.tel[rxtx] = []
        if not t and b != STX:
            self.field(rxtx, ss, es, ['%02X outside a telegram' % b, '%02X' % b])
            return
        t.append((ss, es, b))
        if len(t) >= 2:
            lge = t[1][2]
            if lge < 2:
                self.put(t[0][0], es, self.out_ann, [4, ['LGE %d too small' % lge]])
                self.tel[rxtx] = []
            elif len(t) == lge + 2:
                self.finish(rxtx)
