#!/bin/sh
# Regenerates docs/pulseview-uss.png: real PulseView (Debian's pulseview 0.4.2) under Xvfb,
# showing the first USS telegram of the simulator's uss-param scenario as exported by
# `si trace export --sr`, decoded by sigrok's uart decoder with si's si_uss decoder stacked on
# it (contrib/sigrok, through SIGROKDECODE_DIR). The decoder stack, its options (9600 bit/s,
# even parity), the channel mapping and the zoom come from docs/pulseview-uss.pvs, a PulseView
# session setup file.
#
# Needs: pulseview xvfb imagemagick (apt), and the si binary ($SI, default target/debug/si).
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
si=${SI:-"$root/target/debug/si"}
work=$(mktemp -d)
trap 'rm -rf "$work" 2>/dev/null || true' EXIT
"$si" sim uss-param --record "$work/uss.trace" >/dev/null
"$si" trace export "$work/uss.trace" --sr "$work/uss.sr"
export SIGROKDECODE_DIR="$root/contrib/sigrok" HOME="$work" XDG_RUNTIME_DIR="$work"
xvfb-run -a -s "-screen 0 1000x720x24" sh -c '
  pulseview -c -i "$1/uss.sr" -s "$2" >"$1/pulseview.log" 2>&1 &
  pv=$!
  sleep 10
  import -window root "$3"
  kill "$pv"
  wait "$pv" || true
' sh "$work" "$root/docs/pulseview-uss.pvs" "$root/docs/pulseview-uss.png"
echo "wrote $root/docs/pulseview-uss.png"
