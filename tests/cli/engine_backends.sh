#!/usr/bin/env bash
# outside src/engine/, code reaches the engines through the Engine interface only: no file includes
# a backend's header (engine/mujoco/, engine/dart/) or names a backend's class (a cast to draw a
# MuJoCo run, say: the viewer asks Engine::render_model). Names the offending file and line. Run
# from the root.
set -u
found=$(grep -rnE '#\s*include\s+"engine/(mujoco|dart)/|\b(MujocoEngine|DartEngine)\b' \
  src apps python --include='*.h' --include='*.cc' | grep -v '^src/engine/')
if [ -n "$found" ]; then
  echo "FAIL: a concrete engine outside src/engine/:"
  echo "$found"
  exit 1
fi
echo "ok: no backend header or class outside src/engine/"
