#!/usr/bin/env bash
# Regenerates docs/wireshark-rk512.png: what Wireshark (tshark 4.0, with
# contrib/wireshark/si.lua) shows for the RK 512 scenario's 3964(R)/RK 512 exchange, the packet
# list and the detail of the SEND telegram, rendered as text to PNG with ImageMagick.
# It is tshark's own output, not a drawing: run it to check.
#
# Needs: cargo, tshark, ImageMagick's `convert`, the DejaVu Sans Mono font (fonts-dejavu-core).
set -euo pipefail
cd "$(dirname "$0")/.."
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cargo run -q -p si-cli -- sim rk512 --record "$work/rk512.trace" >/dev/null
cargo run -q -p si-cli -- trace export "$work/rk512.trace" --pcap "$work/rk512.pcapng"
lua="lua_script:contrib/wireshark/si.lua"
{
  echo "\$ tshark -X $lua -r rk512.pcapng -Y exported_pdu"
  tshark -X "$lua" -r "$work/rk512.pcapng" -Y exported_pdu 2>/dev/null | head -n 8
  echo
  echo "\$ tshark -X $lua -r rk512.pcapng -Y 'frame.number == 3' -O si_3964r,si_rk512"
  tshark -X "$lua" -r "$work/rk512.pcapng" -Y 'frame.number == 3' -O si_3964r,si_rk512 2>/dev/null \
    | grep -v '^\s*\[\?Time\|^Frame\|^Exported' | head -n 30
} | cut -c1-110 > "$work/screen.txt"
# Drawn with -annotate on a canvas sized to the text (ImageMagick's label: coder refuses some
# of tshark's bit-field lines as too wide).
lines=$(wc -l < "$work/screen.txt")
convert -size "920x$(( lines * 17 + 30 ))" xc:'#fdfdfd' -fill '#1b1b1b' \
  -font /usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf -pointsize 13 -interline-spacing 1 \
  -annotate +12+22 "$(cat "$work/screen.txt")" docs/wireshark-rk512.png
echo "wrote docs/wireshark-rk512.png"
