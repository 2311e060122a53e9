# Sourced by the measurement scripts once they have read their arguments ($scene, $path,
# $out): installs and builds what they need, works from the repository, sets $osw, and picks
# the scene and walk they run on. With --scene/--path given, those; else the generated power
# plant (TRIANGLES, default 2M) and a walk through it (FRAMES, default 300), built once into
# $out.
# Paths given are relative to where the script was started; then work from the repository.
abs() { [[ -z $1 ]] || realpath -m "$1"; }
scene=$(abs "$scene") path=$(abs "$path") out=$(abs "$out")
cd "$(dirname "$0")/.."
source scripts/tools.sh
mkdir -p "$out"
if [[ -z ${scene:-} ]]; then
  scene="$out/plant.osw"
  [[ -e $scene ]] || $osw build --gen plant --triangles "${TRIANGLES:-2000000}" --seed 1 -o "$scene"
fi
if [[ -z ${path:-} ]]; then
  path="$out/walk.csv"
  [[ -e $path ]] || $osw path --scene "$scene" --kind walk --frames "${FRAMES:-300}" --seed 1 -o "$path"
fi
