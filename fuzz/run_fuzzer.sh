#!/bin/bash
# Runs one fuzzer for CTest: run_fuzzer.sh FUZZER ARTIFACT_DIR [libFuzzer arguments...]
#
# Passes the fuzzer's output and exit status through. When it fails, it then repeats, as the last
# lines, what someone reading only the end of a CI log needs to reproduce the finding: the
# sanitizer's verdict, the top of the first stack, and the input itself (gzip, then base64) where
# it is small enough to print.
set -uo pipefail
fuzzer=$1
artifacts=$2
shift 2

log=$(mktemp)
started=$(mktemp -p "$artifacts" .started.XXXXXX)
trap 'rm -f "$log" "$started"' EXIT

"$fuzzer" "$@" >"$log" 2>&1
status=$?
cat "$log"
[ "$status" -eq 0 ] && exit 0

echo "==== fuzzer failed (exit $status): the finding, repeated ===="
grep -m1 -E '^==[0-9]+== *ERROR|runtime error:|deadly signal|out-of-memory|ALARM: working on the last Unit' "$log"
grep -m1 -E '^SUMMARY: ' "$log"
# The newest artifact this run wrote (crash-, leak-, oom-, timeout-, slow-unit-).
input=$(find "$artifacts" -maxdepth 1 -type f -newer "$started" ! -name '.started.*' \
  -printf '%T@ %p\n' | sort -n | tail -n1 | cut -d' ' -f2-)
if [ -n "$input" ]; then
  encoded=$(gzip -9c "$input" | base64 -w 100)
  lines=$(printf '%s\n' "$encoded" | wc -l)
  echo "input: $(basename "$input"), $(stat -c %s "$input") bytes"
  if [ "$lines" -le 30 ]; then
    echo "input as gzip+base64 (decode: base64 -d | gunzip > input):"
    printf '%s\n' "$encoded"
  else
    echo "(input too large to print here: $lines lines of gzip+base64)"
  fi
fi
echo "top of the first stack:"
grep -m14 -E '^ +#[0-9]+ 0x' "$log" | sed -E 's/^ +//; s/ 0x[0-9a-f]+ in / /' | cut -c1-240
exit "$status"
