#!/usr/bin/env bash
# ctest `install_consumer`: installs the built tree into a temporary prefix, checks `orpe --version`,
# builds tests/install/consumer against the installed package (find_package(orpe), orpe::orpe, no
# project warning flags) and runs it on a small synthetic scene made by the installed CLI.
#   consumer_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$1
src=$2
tmp=$(mktemp -d "${TMPDIR:-/tmp}/orpe_consumer.XXXXXX")
export ORPE_CACHE_DIR="$tmp/model_cache"  # the pipeline's model cache: not the user's ~/.cache
cmake --install "$build" --prefix "$tmp/prefix" > "$tmp/install.log"
test -f "$tmp/prefix/include/orpe/pipeline/object_rpe.h"
test -f "$tmp/prefix/include/orpe/core/version.h"
test -f "$tmp/prefix/lib/cmake/orpe/orpeConfig.cmake"
version=$("$tmp/prefix/bin/orpe" --version)
echo "installed: $version"
[[ $version =~ ^orpe\ [0-9]+\.[0-9]+\.[0-9]+$ ]]
"$tmp/prefix/bin/orpe" synth --out "$tmp/scene" --seed 2 --frames 6 --objects 2 --width 160 \
  --height 120 --preview-stride 0 > "$tmp/synth.log"
generator=()
if command -v ninja > /dev/null; then generator=(-G Ninja); fi
cmake -S "$src/tests/install/consumer" -B "$tmp/build" "${generator[@]}" \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_EXPORT_COMPILE_COMMANDS=ON -DCMAKE_PREFIX_PATH="$tmp/prefix" > "$tmp/configure.log"
cmake --build "$tmp/build" > "$tmp/build.log" || { cat "$tmp/build.log"; exit 1; }
if grep -q -- "-Werror" "$tmp/build/compile_commands.json" 2> /dev/null; then
  echo "the project's -Werror leaked into the consumer's build"; exit 1
fi
OMP_NUM_THREADS=2 "$tmp/build/orpe_consumer" "$tmp/scene" | tail -n 4
rm -rf "$tmp"
