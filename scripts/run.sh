#!/usr/bin/env bash
# `make run`'s last step: the simulated robot and the server, until Ctrl-C (or a TERM) stops both.
# Usage: scripts/run.sh BIN PORT SIM_PORT VIDEO_PORT ROSBRIDGE_URL VIDEO_URL [ROS]
# Both children run in the background and this shell waits on them, so a Ctrl-C reaches its trap at
# once; the trap stops them and exits 0. (The recipe it replaces trapped INT, TERM and EXIT with
# `kill 0`, which signalled the shell itself, ran the trap again, and so on until bash overflowed its
# stack: "make: *** [Makefile:52: run] Segmentation fault" at every Ctrl-C.)
set -u
bin=$1 port=$2 sim_port=$3 video_port=$4 rosbridge_url=$5 video_url=$6 ros=${7:-1}

"$bin/python" -m simulator --port "$sim_port" --video-port "$video_port" --ros "$ros" &
sim=$!
ROSBRIDGE_URL=$rosbridge_url VIDEO_URL=$video_url "$bin/daphne" -b 127.0.0.1 -p "$port" server.asgi:application &
web=$!

stop() {
  trap - INT TERM
  kill -TERM "$web" "$sim" 2>/dev/null
  wait "$web" "$sim" 2>/dev/null
  exit "$1"
}
trap 'stop 0' INT TERM
# The server ending on its own (a port in use, a crash) ends the simulator, and says so. The simulator
# ending does not end the server: it keeps running and shows the robot offline, as with a real robot.
wait -n "$web" "$sim"
status=$?
if kill -0 "$web" 2>/dev/null; then
  echo "run.sh: the simulator stopped (status $status); the server keeps running (Ctrl-C stops it)" >&2
  wait "$web"
  status=$?
fi
echo "run.sh: the server stopped (status $status)" >&2
stop "$status"
