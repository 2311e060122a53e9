# Sourced by the measurement scripts: the scene and walk they run on. With --scene/--path
# given, those; else the generated power plant (TRIANGLES, default 2M) and a walk through it
# (FRAMES, default 300), built once into $out. Needs $out and $osw; sets $scene and $path.
if [[ -z ${scene:-} ]]; then
  scene="$out/plant.osw"
  [[ -e $scene ]] || $osw build --gen plant --triangles "${TRIANGLES:-2000000}" --seed 1 -o "$scene"
fi
if [[ -z ${path:-} ]]; then
  path="$out/walk.csv"
  [[ -e $path ]] || $osw path --scene "$scene" --kind walk --frames "${FRAMES:-300}" --seed 1 -o "$path"
fi
