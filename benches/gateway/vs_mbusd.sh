#!/usr/bin/env bash
# si gateway beside mbusd on the same pty line, slave and client (BENCHMARKS.md).
#
# For each gateway: a socat pty pair, a pymodbus RTU server (unit 1) on one end, the gateway
# on the other end listening on 127.0.0.1, then benches/gateway/client.py: idle CPU for 5 s,
# FC03 x 10 registers in a closed loop with 1 and 8 clients for $SECONDS_PER_RUN s each, idle
# again. Everything is built and run in a temp dir outside the repository; mbusd is built
# from the unmodified copy in ../shared/peers/mbusd, never as a dependency.
#
# usage: benches/gateway/vs_mbusd.sh [SECONDS_PER_RUN (15)] [PAUSE_MS (1)]
#   PAUSE_MS: the pause between requests on the line, the same for both (mbusd -R, si
#   pause_ms); mbusd's minimum is 1 ms, both default to 100 ms.
# env: MBUSD_SRC (default ../shared/peers/mbusd), BAUD (19200), CLIENTS ("1,8"),
#   PACE (0): 1 puts si-testkit's si-pace relay between the gateway's pty and the slave's,
#   so every byte takes its wire time at BAUD 8N1 (a pty alone ignores the baud rate);
#   SI_FRAME_END (unset): si's frame_end line key (gap or length); SI_KEYS: more line keys
#   for si (e.g. "demote_after = 0"); GATEWAYS ("si mbusd"): which to run.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SECS=${1:-15}
PAUSE=${2:-1}
BAUD=${BAUD:-19200}
CLIENTS=${CLIENTS:-1,8}
PACE=${PACE:-0}
SI_FRAME_END=${SI_FRAME_END:-}
SI_KEYS=${SI_KEYS:-}
GATEWAYS=${GATEWAYS:-si mbusd}
MBUSD_SRC=${MBUSD_SRC:-$ROOT/../shared/peers/mbusd}
[ -d "$MBUSD_SRC/src" ] || MBUSD_SRC=/work/shared/peers/mbusd
TMP=$(mktemp -d /tmp/si-vs-mbusd.XXXXXX)
PIDS=()
cleanup() { # the gateway first, then the slave, then socat (the gateway would log the lost pty)
    for ((i = ${#PIDS[@]} - 1; i >= 0; i--)); do kill "${PIDS[i]}" 2>/dev/null || true; done
    wait 2>/dev/null || true
}
trap cleanup EXIT

echo "# temp dir $TMP"
cmake -S "$MBUSD_SRC" -B "$TMP/mbusd" -DCMAKE_BUILD_TYPE=Release >"$TMP/mbusd-build.log" 2>&1
cmake --build "$TMP/mbusd" >>"$TMP/mbusd-build.log" 2>&1
MBUSD=$TMP/mbusd/mbusd
(cd "$ROOT" && CARGO_INCREMENTAL=0 cargo build --release -p si-cli >"$TMP/si-build.log" 2>&1)
SI=${CARGO_TARGET_DIR:-$ROOT/target}/release/si
if [ "$PACE" = 1 ]; then
    (cd "$ROOT" && CARGO_INCREMENTAL=0 cargo build --release -p si-testkit --bin si-pace >>"$TMP/si-build.log" 2>&1)
fi
PACER=${CARGO_TARGET_DIR:-$ROOT/target}/release/si-pace

echo "# $(uname -srm), $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "# $($SI --version), mbusd $(sed -n 's/^project(mbusd VERSION \([0-9.]*\).*/\1/p' "$MBUSD_SRC/CMakeLists.txt") (cmake -DCMAKE_BUILD_TYPE=Release, $(cc --version | head -1))"
echo "# python $(python3 -c 'import sys, pymodbus; print(sys.version.split()[0], "pymodbus", pymodbus.__version__)'), $(socat -V | sed -n 2p)"
echo "# $BAUD 8N1, pause $PAUSE ms, $SECS s per run, clients $CLIENTS, paced wire: $PACE${SI_FRAME_END:+, si frame_end $SI_FRAME_END}"

# A free loopback port.
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

# socat pty pair; sets PTY_A and PTY_B.
pty_pair() {
    local log=$TMP/socat.$1.log
    socat -d -d pty,raw,echo=0 pty,raw,echo=0 >/dev/null 2>"$log" &
    PIDS+=($!)
    for _ in $(seq 50); do
        local n
        n=$(grep -c 'PTY is' "$log" 2>/dev/null || true)
        [ "${n:-0}" -ge 2 ] && break
        sleep 0.1
    done
    read -r PTY_A PTY_B <<<"$(grep -o '/dev/pts/[0-9]*' "$log" | head -2 | tr '\n' ' ')"
}

# pymodbus 3.x RTU server, unit 1, holding register n holds n; prints "ready" when started.
start_slave() {
    rm -f "$TMP/slave.out"
    python3 - "$1" "$BAUD" <<'PY' >"$TMP/slave.out" 2>"$TMP/slave.log" &
import sys, warnings
warnings.filterwarnings("ignore")
from pymodbus.server import StartSerialServer
from pymodbus.datastore import ModbusSequentialDataBlock, ModbusServerContext, ModbusDeviceContext
dev = ModbusDeviceContext(hr=ModbusSequentialDataBlock(1, list(range(100))))
print("ready", flush=True)
StartSerialServer(context=ModbusServerContext(devices={1: dev}, single=False),
                  port=sys.argv[1], baudrate=int(sys.argv[2]), parity="N", stopbits=1, bytesize=8)
PY
    PIDS+=($!)
}

wait_port() {
    for _ in $(seq 100); do
        python3 -c "import socket,sys; socket.create_connection(('127.0.0.1',$1),1)" 2>/dev/null && return 0
        sleep 0.1
    done
    echo "gateway did not listen on $1" >&2
    return 1
}

run() { # name
    local name=$1 port a gw
    port=$(free_port)
    pty_pair "$name"
    a=$PTY_A
    if [ "$PACE" = 1 ]; then
        local relay_a=$PTY_B
        pty_pair "$name-slave"
        rm -f "$TMP/pace.out"
        "$PACER" "$relay_a" "$PTY_A" "$BAUD" >"$TMP/pace.out" 2>"$TMP/pace.log" &
        PIDS+=($!)
        for _ in $(seq 50); do grep -q ready "$TMP/pace.out" 2>/dev/null && break; sleep 0.1; done
    fi
    start_slave "$PTY_B"
    for _ in $(seq 100); do grep -q ready "$TMP/slave.out" 2>/dev/null && break; sleep 0.1; done
    sleep 1 # pymodbus opens its port after importing
    case $name in
    mbusd)
        "$MBUSD" -d -v0 -L "$TMP/mbusd.log" -p "$a" -s "$BAUD" -m 8n1 -A 127.0.0.1 -P "$port" \
            -R "$PAUSE" -W 500 -N 3 -C 32 &
        ;;
    si)
        local frame_end=""
        [ -n "$SI_FRAME_END" ] && frame_end="frame_end = \"$SI_FRAME_END\""
        cat >"$TMP/gw.toml" <<TOML
listen = "127.0.0.1:$port"
max_connections = 32
[[line]]
name = "bench"
device = "$a"
baud = $BAUD
parity = "none"
stop_bits = 1
units = "1"
retries = 2
response_timeout_ms = 500
pause_ms = $PAUSE
$frame_end
$SI_KEYS
TOML
        "$SI" gateway --config "$TMP/gw.toml" >"$TMP/si.log" 2>&1 &
        ;;
    esac
    gw=$!
    PIDS+=($gw)
    wait_port "$port"
    echo "## $name (pid $gw)"
    python3 "$ROOT/benches/gateway/client.py" 127.0.0.1 "$port" "$gw" "$SECS" "$CLIENTS" |
        sed "s/^{/{\"gateway\": \"$name\", /"
    cleanup
    PIDS=()
}

for g in $GATEWAYS; do run "$g"; done
