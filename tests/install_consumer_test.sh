#!/usr/bin/env bash
# Installs the built pcl_ecs into a temporary prefix, then builds and runs against it
# (find_package(pcl_ecs CONFIG REQUIRED)):
#  1. the README's example, verbatim: the code blocks after the '<!-- install_consumer: FILE -->'
#     markers become FILE in an empty project, which must build and simplify data/bunny.pcd;
#  2. tests/consumer, which loads every component (no COMPONENTS) and uses pcl_ecs::surface (Cocone);
#  3. tests/consumer_core, a C++-only project that asks for the core component alone;
# and checks that the library's private headers (src/detail) are not installed.
set -euo pipefail
build_dir=$1
source_dir=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build_dir" --prefix "$work/prefix" > "$work/install.log"
test -f "$work/prefix/include/pcl_ecs/feature_aware_cover_simplify.h"
test -f "$work/prefix/include/pcl_ecs/surface/cocone.h"
for private in simd.h radix_sort.h uninitialised_allocator.h eval/quality_metrics.h; do
  if find "$work/prefix/include" -path "*$private" | grep -q .; then
    echo "install_consumer: the private header $private is installed"; exit 1
  fi
done

mkdir -p "$work/readme"
python3 - "$source_dir/README.md" "$work/readme" <<'PY'
import re, sys, pathlib
text = pathlib.Path(sys.argv[1]).read_text()
blocks = re.findall(r"<!-- install_consumer: (\S+) -->\n```\w*\n(.*?)```", text, re.S)
names = [n for n, _ in blocks]
if sorted(names) != ["CMakeLists.txt", "main.cpp"]:
    sys.exit(f"README: expected the install_consumer blocks CMakeLists.txt and main.cpp, found {names}")
for name, body in blocks:
    (pathlib.Path(sys.argv[2]) / name).write_text(body)
PY
build() {  # build SOURCE_DIR BUILD_DIR
  cmake -S "$1" -B "$2" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_BUILD_TYPE=Release > "$work/configure.log" 2>&1 ||
    { cat "$work/configure.log"; exit 1; }
  cmake --build "$2" > "$work/build.log" 2>&1 || { cat "$work/build.log"; exit 1; }
}
build "$work/readme" "$work/readme-build"
"$work/readme-build/my_app" "$source_dir/data/bunny.pcd" "$work/bunny_small.pcd"
test -s "$work/bunny_small.pcd"

build "$source_dir/tests/consumer" "$work/build"
"$work/build/consumer"

build "$source_dir/tests/consumer_core" "$work/core-build"
"$work/core-build/core_consumer"
