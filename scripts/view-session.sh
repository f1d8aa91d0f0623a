#!/usr/bin/env bash
# The `hair view` session of docs/view.md, driven by real X events: under Xvfb, `xdotool`
# chooses Water and drags it across the head, then Dryer and a second drag, while
# `hair view salon --frames 240` runs; the window writes its screenshot, metrics and recording
# when the frames are done. Then `hair run` replays the recording headless and the two state
# hashes are compared.
#
#   scripts/view-session.sh [OUT_DIR]      (default: out; needs xvfb-run, xauth, xdotool)
#
# HAIR (default target/release/hair) names the binary; build it first with
# `cargo build --release`.
set -euo pipefail
out=${1:-out}
hair=${HAIR:-target/release/hair}
if [ -z "${HAIR_VIEW_SESSION_INNER:-}" ]; then
    mkdir -p "$out"
    HAIR_VIEW_SESSION_INNER=1 xvfb-run -a -s "-screen 0 1280x800x24" bash "$0" "$out"
    "$hair" run "$out/session.ron" --out "$out/replay" > /dev/null
    python3 - "$out" <<'PY'
import json, sys
out = sys.argv[1]
view = json.load(open(f"{out}/view.json"))
replay = json.load(open(f"{out}/replay/summary.json"))
print(f"view   state_hash {view['state_hash']}  water_kg {view['salon']['water_kg']:.3f}  events {view['events']}")
print(f"replay state_hash {replay['state_hash']}  ms_per_frame {replay['ms_per_frame']:.2f} (simulation and tools, headless)")
print("same state" if view["state_hash"] == replay["state_hash"] else "DIFFERENT STATE")
sys.exit(0 if view["state_hash"] == replay["state_hash"] else 1)
PY
    exit
fi

layout="$out/view-layout.txt"
"$hair" view salon --frames 240 --print-layout --screenshot "$out/view.png" \
    --metrics "$out/view.json" --record "$out/session.ron" --force > "$layout" &
app=$!
for _ in $(seq 600); do
    grep -q '^layout view ' "$layout" 2>/dev/null && break
    sleep 0.2
done
rect() { grep "^layout $1 " "$layout" | awk '{print $(NF-3), $(NF-2), $(NF-1), $NF}'; }
centre() { read -r x y w h <<< "$(rect "$1")"; echo "$(( ${x%.*} + ${w%.*} / 2 )) $(( ${y%.*} + ${h%.*} / 2 ))"; }
window=$(xdotool search --sync --name "hair view" | head -n 1)
read -r vx vy vw vh <<< "$(rect view)"
vx=${vx%.*}; vy=${vy%.*}; vw=${vw%.*}; vh=${vh%.*}
stroke() {
    # Choose a palette button, then drag across the head from left to right.
    read -r bx by <<< "$(centre "palette $1")"
    xdotool mousemove --window "$window" "$bx" "$by"; sleep 0.3
    xdotool mousedown 1; sleep 1; xdotool mouseup 1; sleep 0.5
    local cy=$(( vy + vh * 45 / 100 ))
    xdotool mousemove --window "$window" $(( vx + vw * 38 / 100 )) "$cy"; sleep 0.3
    xdotool mousedown 1
    for k in $(seq 12); do
        sleep 0.25
        xdotool mousemove --window "$window" $(( vx + vw * (38 + 2 * k) / 100 )) "$cy"
    done
    sleep 0.5; xdotool mouseup 1; sleep 0.3
}
stroke water
stroke dryer
wait "$app"
