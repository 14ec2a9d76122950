##
## This file is part of the si project (SIMATIC ET 200S serial interface protocols).
## SPDX-License-Identifier: MIT OR Apache-2.0
##

'''
This decoder stacks on top of the 'uart' PD and decodes the Siemens 3964(R)
procedure: the control characters STX, DLE and NAK, and the blocks between
them (DLE doubling undone, end DLE ETX, block check character BCC in 3964R).

Both UART directions are decoded; a block is the characters a station sends
after its STX has been answered by the partner's DLE.

Its Python output is one tuple per block for stacked decoders (si_rk512):
('BLOCK', rxtx, (data, bcc_ok)) from the block's first to its last character.
'''

from .pd import Decoder
