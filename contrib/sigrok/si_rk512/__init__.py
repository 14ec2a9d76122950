##
## This file is part of the si project (SIMATIC ET 200S serial interface protocols).
## SPDX-License-Identifier: MIT OR Apache-2.0
##

'''
This decoder stacks on top of the 'si_3964r' PD and decodes the RK 512
telegrams in its blocks: command telegrams (SEND, FETCH, with data type,
DB, DW offset, length, coordination flag and CPU), continuation telegrams
and reaction telegrams with their error number.
'''

from .pd import Decoder
