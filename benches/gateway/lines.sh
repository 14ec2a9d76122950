#!/usr/bin/env bash
# Many lines in one si gateway process: threads, memory per line, idle CPU, and the first and
# last line answering (BENCHMARKS.md "Lines per process"). The lines are pseudo-
# terminals from os.openpty held by benches/gateway/lines.py, which also simulates the RTU
# slaves; si is built in release mode.
#
# usage: benches/gateway/lines.sh [COUNTS (1,100,1000)] [lines.py options]
#   e.g. benches/gateway/lines.sh 1,100,1000 --per-face 250 --idle 10 --parallel 8
#   --per-face P: lines per listening address (unit ids 1..P on each; 1 = mbusd's one port
#   per line). The lines need 1 descriptor each in the gateway and 2 in lines.py; both raise
#   their soft RLIMIT_NOFILE to the hard one. 1,000 lines need kernel.pty.max >= 1,000.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/../.." && pwd)
COUNTS=${1:-1,100,1000}
shift || true
(cd "$ROOT" && CARGO_INCREMENTAL=0 cargo build --release -p si-cli >&2)
SI=${CARGO_TARGET_DIR:-$ROOT/target}/release/si

echo "# $(uname -srm), $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "# $($SI --version) at $(git -C "$ROOT" rev-parse --short HEAD), python $(python3 -c 'import sys; print(sys.version.split()[0])')"
echo "# RLIMIT_NOFILE $(ulimit -Sn)/$(ulimit -Hn), kernel.pty.max $(cat /proc/sys/kernel/pty/max), $(date -u +%F)"
echo "# lines $COUNTS $*"
python3 "$ROOT/benches/gateway/lines.py" "$SI" "$COUNTS" "$@"
