#!/usr/bin/env bash
# Issue 23's acceptance runs of the model watch, through the binary (not run by CI: about
# 10 minutes on two cores). Usage: scripts/watch_acceptance.sh [TOPSIDE] [OUT_DIR]
#  1. Six fault kinds at two sizes on the transect dive (autopilot on, sensor noise, fault
#     at 300 s): when the first change alert begins, what it ranks first and second.
#  2. 8 hours of fault-free dives (4 x 2 h; seeds 1-4; transect and survey; model3, model1
#     and model2 each as the vehicle and the autopilot): every alert raised.
set -euo pipefail
B=${1:-target/debug/topside}
OUT=${2:-target/watch_acceptance}
HERE=$(cd "$(dirname "$0")/.." && pwd)
S=$HERE/config/scripts
mkdir -p "$OUT"
echo "== faults (fault at 300 s)"
for spec in thrust-loss:port:0.4 thrust-loss:port:0.2 buoyancy:3 buoyancy:1.5 drag:2.5 drag:1.75 \
            snag:15 snag:7.5 depth-sensor:stuck depth-sensor:jump:0.5 compass:25 compass:12.5; do
  n=$(echo "$spec" | tr ':.' '__')
  "$B" record --sim --fast --duration-s 400 --script "$S/transect.toml" --fault "$spec@300" \
      --video none --out "$OUT/$n.mcap" --json 2>/dev/null > "$OUT/$n.json"
  python3 - "$spec" "$OUT/$n.json" <<'PY'
import json, sys
spec, f = sys.argv[1], sys.argv[2]
w = json.load(open(f))["watch"]
ch = [a for a in w["alerts"] if a["kind"] == "change"]
mm = [a for a in w["alerts"] if a["kind"] == "mismatch"]
if not ch:
    print(f"{spec:24s} NO CHANGE ALERT  mismatches={len(mm)}"); sys.exit()
a, c = ch[0], ch[0]["causes"]
second = c[1]["cause"] if len(c) > 1 else "-"
print(f"{spec:24s} begins {a['t_s'] - 300:+6.2f} s (raised {a['detected_s'] - 300:+6.2f} s) "
      f"{a['channel']:7s} first {c[0]['cause']} ({c[0]['size']} {c[0]['unit']}, score {c[0]['score']}) "
      f"second {second}; changes {len(ch)}, mismatches {len(mm)}")
PY
done
echo "== 8 h without faults"
run() { # name script seed model
  "$B" record --sim --fast --duration-s 7200 --script "$S/$2.toml" --seed "$3" --model "$4" \
      --vehicle "$HERE/config/models/$4.toml" --video none --out "$OUT/clean_$1.mcap" --json \
      2>/dev/null > "$OUT/clean_$1.json"
  python3 -c "
import json; w = json.load(open('$OUT/clean_$1.json'))['watch']
print('$1: $2, seed $3, $4: judged %.0f s, alerts %s' % (w['judged_s'], [(a['kind'], a['channel'], a['t_s']) for a in w['alerts']]))"
}
run a transect 1 model3
run b transect 2 model3
run c survey 3 model1
run d transect 4 model2
