#!/usr/bin/env bash
# The shape the project keeps, checked in CI: README.md at most 160 lines of at most 200
# characters; each measurement page at most 300 lines, naming its commit in its first ten; no
# comment in crates/*/src carrying a measured figure (milliseconds, megabytes,
# gigabytes or a ratio written "1.5x"): measured numbers and their history belong in
# docs/measurements/, and the code says why in a sentence and links there. The figures of
# settings and limits are what the code sets, and are allowed below by file and text.
set -euo pipefail
cd "$(dirname "$0")/.."
allowed=(
  'crates/cull/src/hzb.rs|ndc x = (2x + 1)'                  # a formula
  'crates/cull/src/ovc.rs|1 ms'                              # the tests' fake clock
  'crates/cull/src/ovc.rs|0 ms'
  'crates/osw/src/cmd_build.rs|about 6 GB'                   # the limit's reason
  'crates/osw/src/cmd_link.rs|200 ms later'                  # Linux's retransmission timeout
  'crates/osw/src/cmd_link.rs|about 6 MB'                    # the relay's buffer
  'crates/scene/src/limits.rs|near 200 MB'                   # the limit's reason
  'crates/wire/src/net.rs|50 ms doubling to 1 s'             # the backoff
  'crates/wire/src/limits.rs|15 MB dense, 73 MB at worst'    # the limit's reason
)
bad=0
while IFS= read -r hit; do
  file=${hit%%:*} text=${hit#*:*:}
  ok=0
  for a in "${allowed[@]}"; do
    [[ $file == "${a%%|*}" && $text == *"${a#*|}"* ]] && { ok=1; break; }
  done
  ((ok)) || { echo "check-shape: a measured figure in a comment: $hit" >&2; bad=1; }
done < <(grep -rnE '//.*[0-9](\.[0-9]+)? ?(ms|GB|MB|x)\b' crates/*/src || true)
lines=$(wc -l <README.md)
((lines <= 160)) || { echo "check-shape: README.md has $lines lines (at most 160)" >&2; bad=1; }
if long=$(awk 'length > 200 { print FNR }' README.md) && [[ -n $long ]]; then
  echo "check-shape: README.md lines over 200 characters: $long" >&2
  bad=1
fi
for page in docs/measurements/*.md; do
  n=$(wc -l <"$page")
  ((n <= 300)) || { echo "check-shape: $page has $n lines (at most 300: split it by topic)" >&2; bad=1; }
  head -10 "$page" | grep -qE '\b[0-9a-f]{7,40}\b' || { echo "check-shape: $page names no commit in its first ten lines" >&2; bad=1; }
done
exit $bad
