#!/usr/bin/env bash
# Breakage check ("mutants"): applies each breakage of scripts/mutants.list, one at a time, to a scratch
# copy of the committed tree (a git worktree of HEAD under /tmp), builds the listed targets there
# (its own build dir; ccache makes every rebuild after the first incremental) and runs the listed
# tests. A breakage that no test catches SURVIVES. Prints one line per breakage and a summary; exits 1
# when a breakage survived (or no longer applies: the code it edits moved).
#
#   bash scripts/mutants.sh                 # every breakage
#   bash scripts/mutants.sh ekf_symmetry    # only those whose name contains this
# Environment: ORPE_MUTANTS_DIR (scratch copy, default /tmp/orpe_mutants_$USER: kept between runs so
# its build stays warm), ORPE_JOBS (build jobs, default 2), ORPE_DATA_DIR (real data for the tests).
# Run it on a committed tree: the scratch copy is HEAD, not the working tree's edits.
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
filter=${1:-}
scratch=${ORPE_MUTANTS_DIR:-/tmp/orpe_mutants_${USER:-$(id -un)}}
jobs=${ORPE_JOBS:-2}
export ORPE_DATA_DIR=${ORPE_DATA_DIR:-$(cd .. && pwd)/shared/data}
export OMP_WAIT_POLICY=passive
head=$(git rev-parse HEAD)

if [ -d "$scratch/.git" ] || [ -f "$scratch/.git" ]; then
  git -C "$scratch" checkout -q --detach "$head"
  git -C "$scratch" checkout -q -- .
else
  rm -rf "$scratch"
  git worktree add -q --detach "$scratch" "$head"
fi
# ccache hits for the library objects: paths under the scratch copy are rewritten relative, like
# those of the main checkout's builds.
export CCACHE_BASEDIR=$(dirname "$scratch")
build="$scratch/build"
if [ ! -f "$build/CMakeCache.txt" ]; then
  (cd "$scratch" && cmake --preset release -B "$build" > /dev/null)
fi

python3 - "$repo/scripts/mutants.list" > "$scratch/.mutants.tsv" <<'PY'
import sys
blocks, cur = [], None
for line in open(sys.argv[1]):
    line = line.rstrip("\n")
    if line.startswith("## "):
        cur = {"name": line[3:].strip()}
        blocks.append(cur)
    elif cur is not None and ":" in line and not line.startswith("#"):
        k, v = line.split(":", 1)
        cur[k.strip()] = v.strip()
for b in blocks:
    missing = [k for k in ("file", "old", "new", "targets", "tests", "why") if k not in b]
    if missing:
        sys.exit(f"mutants.list: breakage '{b['name']}' lacks {missing}")
    print("\x1f".join([b["name"], b["file"], b["old"], b["new"], b["targets"], b["tests"], b["why"]]))
PY

apply() {  # file old new: exact replacement of a single occurrence (\n = newline)
  python3 - "$@" <<'PY'
import sys
path, old, new = sys.argv[1], sys.argv[2].replace("\\n", "\n"), sys.argv[3].replace("\\n", "\n")
s = open(path).read()
n = s.count(old)
if n != 1:
    sys.exit(f"{path}: the text to break occurs {n} times (expected once): {old!r}")
open(path, "w").write(s.replace(old, new))
PY
}

# A warm build of the unmodified tree first (so a breakage's build is incremental).
echo "building the unmodified tree in $build ..."
all_targets=$(cut -d $'\x1f' -f5 "$scratch/.mutants.tsv" | tr ' ' '\n' | sort -u | tr '\n' ' ')
cmake --build "$build" -j "$jobs" --target $all_targets > "$scratch/.build.log" 2>&1 ||
  { echo "the unmodified tree does not build: $scratch/.build.log"; exit 1; }

survived=0 killed=0 broken=0 total=0
results=()
while IFS=$'\x1f' read -r name file old new targets tests why; do
  [ -n "$filter" ] && [[ "$name" != *"$filter"* ]] && continue
  total=$((total + 1))
  git -C "$scratch" checkout -q -- .
  t0=$(date +%s)
  if ! apply "$scratch/$file" "$old" "$new" 2> "$scratch/.apply.log"; then
    line="DOES NOT APPLY  $name: $(cat "$scratch/.apply.log")"
    broken=$((broken + 1))
  elif ! cmake --build "$build" -j "$jobs" --target $targets > "$scratch/.build.log" 2>&1; then
    line="BUILD FAILED    $name (see $scratch/.build.log)"
    broken=$((broken + 1))
    cp "$scratch/.build.log" "$scratch/.build-$total.log"
  elif ctest --test-dir "$build" -j "$jobs" -R "$tests" --timeout 300 > "$scratch/.ctest.log" 2>&1; then
    n=$(grep -c "Test *#" "$scratch/.ctest.log" || true)
    line="SURVIVED        $name ($n tests passed: $tests)"
    survived=$((survived + 1))
  else
    failed=$(grep -E "^\s+[0-9]+ - " "$scratch/.ctest.log" | sed -E 's/^\s+[0-9]+ - ([^ ]+).*/\1/' | tr '\n' ' ')
    n=$(grep -c "Test *#" "$scratch/.ctest.log" || true)
    if [ "$n" = 0 ]; then
      line="NO TESTS RAN    $name (regex '$tests')"
      broken=$((broken + 1))
    else
      line="killed          $name, by: $failed"
      killed=$((killed + 1))
    fi
  fi
  line="$line [$(( $(date +%s) - t0 )) s]"
  echo "$line"
  results+=("$line")
done < "$scratch/.mutants.tsv"
git -C "$scratch" checkout -q -- .

echo "mutants: $total breakages at $(git rev-parse --short HEAD): $killed killed, $survived survived, $broken did not apply/build"
[ "$survived" = 0 ] && [ "$broken" = 0 ]
