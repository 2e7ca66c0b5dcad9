#!/usr/bin/env bash
# Identifies a Staubli TX40 from one real 9 s excitation run, logged on the motor side at 5 kHz
# (FIGAROH's published data set, Apache-2.0; see tests/data/README.md), and predicts the last
# 30 % of the run from a fit of its first 70 %.
#   usage: examples/staubli_tx40.sh OUT_DIR [--force]
# Writes OUT_DIR/tx40_motor_log.csv (the two logged files joined, with a time column),
# OUT_DIR/fit.json (the whole run) and OUT_DIR/split.json (validation[0]: the last 30 %).
# The sid_* tools come from PATH when they are there, else from build/release/apps/.
set -euo pipefail
if [ $# -lt 1 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then
  sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'
  [ $# -ge 1 ] && exit 0 || exit 2
fi
out=$1
force=()
[ "${2:-}" = "--force" ] && force=(--force)
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
data="$root/tests/data/staubli_tx40"
if command -v sid_identify >/dev/null 2>&1; then
  identify=sid_identify
elif [ -x "$root/build/release/apps/sid_identify" ]; then
  identify="$root/build/release/apps/sid_identify"
else
  echo "staubli_tx40.sh: sid_identify is neither on PATH nor in build/release/apps (run" \
       "bash scripts/run first)" >&2
  exit 2
fi
mkdir -p "$out"
log="$out/tx40_motor_log.csv"
if [ -e "$log" ] && [ ${#force[@]} -eq 0 ]; then
  echo "staubli_tx40.sh: refusing to overwrite '$log' (add --force)" >&2
  exit 2
fi
# The log has no time column: its sample period is 0.2 ms (FIGAROH's config, ts).
paste -d, "$data/pos_read_data.csv" "$data/curr_data.csv" | awk -F, '
  NR == 1 { print "t,q1,q2,q3,q4,q5,q6,tau1,tau2,tau3,tau4,tau5,tau6"; next }
  { printf "%.4f,%s\n", (NR - 2) * 0.0002, $0 }' > "$log"

robot=(--robot "$data/tx40_mdh_modified.urdf" --transmission "$data/tx40_transmission.yaml")
echo "== the whole run"
"$identify" "${robot[@]}" --json "$out/fit.json" "${force[@]}" "$log"
echo
echo "== the first 70 % fitted, the last 30 % predicted"
"$identify" "${robot[@]}" --validate-fraction 0.3 --json "$out/split.json" "${force[@]}" "$log"
