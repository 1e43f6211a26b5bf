# Sourced by the quality-only experiment scripts (cap_experiment.sh, gap_experiment.sh) after they
# set `here` (bench/): the build, the shared data and a temporary directory removed on exit.
root=$(dirname "$here")
build=${BUILD_DIR:-$root/build}
data=${PCL_ECS_SHARED_DATA_DIR:-$root/../shared/data}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
