##
## This file is part of the si project (SIMATIC ET 200S serial interface protocols).
## SPDX-License-Identifier: MIT OR Apache-2.0
##

'''
This decoder stacks on top of the 'uart' PD and decodes Siemens USS
telegrams: STX LGE ADR <net data> BCC, the net data split into the parameter
channel PKW (PKE with AK/SPM/PNU, IND, PWE) and the process data PZD.

Both UART directions are decoded (master requests and drive answers on an
RS-485 bus appear on whichever channel carries them).
'''

from .pd import Decoder
