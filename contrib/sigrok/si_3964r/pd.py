##
## This file is part of the si project (SIMATIC ET 200S serial interface protocols).
## SPDX-License-Identifier: MIT OR Apache-2.0
##
## The procedure: [ET200S SI] §2.7 (3964(R) procedure: control characters,
## block check character, sending and receiving).

import sigrokdecode as srd

STX, ETX, DLE, NAK = 0x02, 0x03, 0x10, 0x15
RX, TX = 0, 1
NAMES = ('RX', 'TX')

class Decoder(srd.Decoder):
    api_version = 3
    id = 'si_3964r'
    name = '3964(R)'
    longname = 'Siemens 3964(R) procedure'
    desc = 'Siemens 3964 / 3964(R) point-to-point procedure (STX, DLE, NAK, blocks with BCC).'
    license = 'mit'
    inputs = ['uart']
    outputs = ['si_3964r']
    tags = ['Embedded/industrial']
    options = (
        {'id': 'bcc', 'desc': 'Block check character (3964R)', 'default': 'yes',
            'values': ('yes', 'no')},
    )
    annotations = (
        ('rx-control', 'RX control character'),
        ('rx-block', 'RX block'),
        ('rx-data', 'RX data byte'),
        ('tx-control', 'TX control character'),
        ('tx-block', 'TX block'),
        ('tx-data', 'TX data byte'),
        ('error', 'Error'),
    )
    annotation_rows = (
        ('rx-bytes', 'RX bytes', (0, 2)),
        ('rx-blocks', 'RX blocks', (1,)),
        ('tx-bytes', 'TX bytes', (3, 5)),
        ('tx-blocks', 'TX blocks', (4,)),
        ('errors', 'Errors', (6,)),
    )

    def __init__(self):
        self.reset()

    def reset(self):
        # Per direction: 'idle', 'stx' (sent STX, waiting for the partner's DLE), 'block'.
        self.state = ['idle', 'idle']
        # Per direction: (ss, raw bytes, data bytes, pending DLE: its ss, or 'end' after
        # DLE ETX, or None).
        self.block = [None, None]

    def start(self):
        self.out_ann = self.register(srd.OUTPUT_ANN)
        self.out_python = self.register(srd.OUTPUT_PYTHON)

    def ann(self, ss, es, rxtx, kind, texts):
        base = 0 if rxtx == RX else 3
        cls = {'control': 0, 'block': 1, 'data': 2}[kind] + base
        self.put(ss, es, self.out_ann, [cls, texts])

    def control(self, ss, es, rxtx, b):
        name = {STX: 'STX', DLE: 'DLE', NAK: 'NAK'}.get(b)
        if name is None:
            self.ann(ss, es, rxtx, 'data', ['char %02X' % b, '%02X' % b])
            return
        self.ann(ss, es, rxtx, 'control', [name, name[0]])
        other = 1 - rxtx
        if b == STX:
            self.state[rxtx] = 'stx'
        elif b == DLE and self.state[other] == 'stx':
            # The partner's STX answered: its block follows.
            self.state[other] = 'block'
            self.block[other] = None

    def end_block(self, es, rxtx, bcc_ok):
        ss, raw, data, _ = self.block[rxtx]
        hexes = ' '.join('%02X' % x for x in raw)
        verdict = '' if bcc_ok is None else (' BCC ok' if bcc_ok else ' BCC error')
        self.ann(ss, es, rxtx, 'block', ['block %s%s' % (hexes, verdict),
                                         'block %d B%s' % (len(data), verdict)])
        if bcc_ok is False:
            self.put(ss, es, self.out_ann, [6, ['BCC error', 'BCC']])
        self.put(ss, es, self.out_python,
                 ['BLOCK', rxtx, (bytes(data), bcc_ok is not False)])
        self.state[rxtx] = 'idle'
        self.block[rxtx] = None

    def decode(self, ss, es, data):
        ptype, rxtx, pdata = data
        if ptype in ('PARITY ERROR', 'BREAK'):
            self.put(ss, es, self.out_ann, [6, ['%s %s' % (NAMES[rxtx], ptype.lower())]])
            return
        if ptype == 'FRAME' and not pdata[1]:
            self.put(ss, es, self.out_ann, [6, ['%s framing error' % NAMES[rxtx]]])
            return
        if ptype != 'DATA':
            return
        b = pdata[0]
        if self.state[rxtx] != 'block':
            self.control(ss, es, rxtx, b)
            return
        if self.block[rxtx] is None:
            self.block[rxtx] = (ss, [], [], None)
        bss, raw, dat, dle = self.block[rxtx]
        raw.append(b)
        if dle == 'end':
            # The BCC after DLE ETX: XOR of every block character from the first to ETX.
            bcc = 0
            for x in raw[:-1]:
                bcc ^= x
            self.ann(ss, es, rxtx, 'data', ['BCC %02X' % b, 'BCC'])
            self.end_block(es, rxtx, bcc == b)
            return
        if dle is not None:
            # The DLE before is annotated together with what follows it.
            dss = dle
            if b == DLE:
                dat.append(DLE)
                self.ann(dss, es, rxtx, 'data', ['DLE DLE (data 10)', '10'])
                self.block[rxtx] = (bss, raw, dat, None)
            elif b == ETX:
                self.ann(dss, es, rxtx, 'data', ['DLE ETX (block end)', 'DLE ETX'])
                if self.options['bcc'] == 'yes':
                    self.block[rxtx] = (bss, raw, dat, 'end')
                else:
                    self.end_block(es, rxtx, None)
            else:
                self.put(dss, es, self.out_ann,
                         [6, ['DLE followed by %02X inside a block' % b, 'DLE?']])
                self.state[rxtx] = 'idle'
                self.block[rxtx] = None
            return
        if b == DLE:
            self.block[rxtx] = (bss, raw, dat, ss)
        else:
            dat.append(b)
            self.ann(ss, es, rxtx, 'data', ['%02X' % b])
