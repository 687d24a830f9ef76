#!/usr/bin/env bash
# Runs every fuzz target for SECONDS each (default 240), one after the other, with the issue's
# memory cap, and prints one line per target: executions, seconds, crash/OOM/timeout artifacts.
#   cd fuzz && cargo +nightly fuzz build -O && cd .. && tools/fuzz/campaign.sh 240
# With RUNS=N set, each target instead runs exactly N executions (SECONDS is then only a time cap):
#   RUNS=10000000 tools/fuzz/campaign.sh 7200
# The working corpus is fuzz/corpus-local/<target> (not committed), seeded from the committed
# fuzz/corpus/<target> plus any real files you copied into fuzz/corpus-local/<target> first.
set -u
seconds=${1:-240}
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=$root/fuzz/target/x86_64-unknown-linux-gnu/release
targets=${TARGETS:-"ply spz splat ksplat compressed_ply colmap_bin colmap_txt transforms_json sam_json sam_metadata_csv npy npz label_png rle_string config_toml view_request"}
mkdir -p "$root/fuzz/corpus-local" "$root/fuzz/artifacts" "$root/fuzz/logs"
echo -e "target\texecutions\tseconds\tartifacts"
for t in $targets; do
  mkdir -p "$root/fuzz/corpus-local/$t" "$root/fuzz/artifacts/$t"
  log=$root/fuzz/logs/$t.log
  "$bin/$t" "$root/fuzz/corpus-local/$t" "$root/fuzz/corpus/$t" \
    -rss_limit_mb=2048 -max_total_time="$seconds" ${RUNS:+-runs=$RUNS} -print_final_stats=1 \
    -artifact_prefix="$root/fuzz/artifacts/$t/" > "$log" 2>&1
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  elapsed=$(grep -o 'Done [0-9]* runs in [0-9]* second' "$log" | grep -o 'in [0-9]*' | grep -o '[0-9]*' | tail -1)
  secs=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' | tail -1)
  echo -e "$t\t${execs:-?}\t${elapsed:-$seconds} (${secs:-?}/s)\t$(ls "$root/fuzz/artifacts/$t" | wc -l)"
done
