#!/usr/bin/env bash
# The production topology on this machine: nginx (TLS, HTTP/2, the site in deploy/nginx/) in
# front of two Daphne processes, two robot links (active + standby), a Celery worker and beat,
# against the simulator, on PostgreSQL and Redis with a private database and key prefix.
#
#   scripts/stack.sh up      start everything, wait until the robot is live through nginx
#   scripts/stack.sh down    stop exactly what `up` started (pid files in $STACK_DIR/pids)
#   scripts/stack.sh status  which of its processes are running
#   scripts/stack.sh restart NAME...   stop and start some (sim link-a link-b web-a web-b worker beat nginx)
#
# Settings (environment): STACK_DIR (var/stack), STACK_HTTPS_PORT (8443), STACK_HTTP_PORT (8480),
# STACK_WEB_PORTS ("8401 8402"), STACK_SIM_PORT (9490), STACK_VIDEO_PORT (8490),
# DATABASE_URL (postgres://postgres@127.0.0.1:5432/cyborg_stack, created if missing),
# REDIS_URL (redis://127.0.0.1:6379/0), CHANNEL_LAYER_PREFIX (cyborg-stack),
# ROSBRIDGE_URL (unset: the bundled simulator is started, with STACK_SIM_ARGS),
# STACK_ENV (extra NAME=value lines for the environment file),
# STACK_UPLINK (set: the robot dials in: an uplink agent beside the simulator connects through nginx at
# /uplink/ to the active link on STACK_UPLINK_PORT (8493), whose relays use 8494 and 8495).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BIN=$ROOT/.venv/bin

STACK_DIR=$(realpath -m "${STACK_DIR:-var/stack}")
HTTPS_PORT=${STACK_HTTPS_PORT:-8443}
HTTP_PORT=${STACK_HTTP_PORT:-8480}
read -r WEB_A WEB_B <<<"${STACK_WEB_PORTS:-8401 8402}"
SIM_PORT=${STACK_SIM_PORT:-9490}
VIDEO_PORT=${STACK_VIDEO_PORT:-8490}
LINK_PORTS=${STACK_LINK_PORTS:-127.0.0.1:8491,127.0.0.1:8492}
UPLINK_PORT=${STACK_UPLINK_PORT:-8493}
PIDS=$STACK_DIR/pids
LOGS=$STACK_DIR/logs
ENV_FILE=$STACK_DIR/cyborg.env
NGINX=${NGINX:-$(command -v nginx || echo /usr/sbin/nginx)}

say() { echo "stack: $*" >&2; }

wait_port() {  # port seconds name
  local deadline=$((SECONDS + $2))
  until (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; do
    if ((SECONDS >= deadline)); then say "$3 is not listening on $1 after $2 s; see $LOGS/"; return 1; fi
    sleep 0.1
  done
}

# The example production environment, with this machine's services, ports and paths; only its owner
# may read it (the secret key, the database's password).
write_env() {
  local key
  key=$("$BIN/python" -c "import secrets; print(secrets.token_urlsafe(50))")
  install -m 600 /dev/null "$ENV_FILE"
  {
    grep -v -E '^(SECRET_KEY|ALLOWED_HOSTS|CSRF_TRUSTED_ORIGINS|VAR_DIR|DATABASE_URL|REDIS_URL|CHANNEL_LAYER_PREFIX|ROSBRIDGE_URL|VIDEO_URL|ROBOT_LINK_DIRECT_ADDRESSES|SECURE_HSTS_SECONDS)=' \
      deploy/cyborg.env.example
    echo "SECRET_KEY=$key"
    echo "ALLOWED_HOSTS=localhost,127.0.0.1"
    echo "CSRF_TRUSTED_ORIGINS=https://localhost:$HTTPS_PORT,https://127.0.0.1:$HTTPS_PORT"
    # A browser remembers HSTS per host, whatever the port: keep it short for localhost.
    echo "SECURE_HSTS_SECONDS=60"
    echo "VAR_DIR=$STACK_DIR/var"
    echo "DATABASE_URL=${DATABASE_URL:-postgres://postgres@127.0.0.1:5432/cyborg_stack}"
    echo "REDIS_URL=${REDIS_URL:-redis://127.0.0.1:6379/0}"
    echo "CHANNEL_LAYER_PREFIX=${CHANNEL_LAYER_PREFIX:-cyborg-stack}"
    if [[ -n "${STACK_UPLINK:-}" ]]; then
      echo "UPLINK=true"
      echo "UPLINK_LISTEN=127.0.0.1:$UPLINK_PORT"
      echo "UPLINK_ROSBRIDGE_PORT=$((UPLINK_PORT + 1))"
      echo "UPLINK_VIDEO_PORT=$((UPLINK_PORT + 2))"
    else
      echo "ROSBRIDGE_URL=${ROSBRIDGE_URL:-ws://127.0.0.1:$SIM_PORT}"
      echo "VIDEO_URL=${VIDEO_URL:-http://127.0.0.1:$VIDEO_PORT}"
    fi
    echo "ROBOT_LINK_DIRECT_ADDRESSES=$LINK_PORTS"
    echo "CYBORG_STACK=$STACK_DIR"  # marks our processes (checked before any is signalled)
    if [[ -n "${STACK_ENV:-}" ]]; then printf "%s\n" "$STACK_ENV"; fi
  } >"$ENV_FILE"
}

# Run a command with the stack's environment.
in_env() { (set -a; . "$ENV_FILE"; set +a; exec "$@"); }

# Start NAME in its own session, output to logs/NAME.log, pid to pids/NAME.pid. As the systemd units
# do (Restart=always, RestartSec=1), a process that dies on its own is started again a second later:
# pids/NAME.pid is the session's keeper, pids/NAME.child the process it runs now. Stopping (or
# killing) the whole session ends both. The child's pid is written beside and renamed, so a reader
# never sees the file empty.
start() {
  local name=$1; shift
  (set -a; . "$ENV_FILE"; set +a; exec setsid bash -c '
    child=$1; shift
    trap '"'"'kill -TERM "$pid" 2>/dev/null; wait "$pid"; exit 0'"'"' TERM INT
    while :; do
      "$@" & pid=$!
      echo "$pid" >"$child.new" && mv -f "$child.new" "$child"
      wait "$pid" || true
      echo "stack.sh: $(date -Is) exited; starting it again in 1 s"
      sleep 1
    done' keep "$PIDS/$name.child" "$@" >>"$LOGS/$name.log" 2>&1 </dev/null) &
  echo $! >"$PIDS/$name.pid"
}

# Every process of the stack, in start order.
names() {
  if [[ -z "${ROSBRIDGE_URL:-}" ]]; then echo sim; fi
  echo link-a link-b web-a web-b worker beat nginx
  if [[ -n "${STACK_UPLINK:-}" ]]; then echo agent; fi
}

launch() {
  case $1 in
    sim) start sim "$BIN/python" -m simulator --port "$SIM_PORT" --video-port "$VIDEO_PORT" ${STACK_SIM_ARGS:-} ;;
    link-a | link-b) start "$1" env ROBOT_LINK_NAME="$1" "$BIN/python" manage.py robotlink ;;
    web-a) start web-a "$BIN/daphne" -b 127.0.0.1 -p "$WEB_A" server.asgi:application ;;
    web-b) start web-b "$BIN/daphne" -b 127.0.0.1 -p "$WEB_B" server.asgi:application ;;
    worker) start worker "$BIN/celery" -A cyborg_site worker --loglevel=INFO --concurrency=1 --without-gossip \
              --without-mingle ;;
    beat) start beat "$BIN/celery" -A cyborg_site beat --loglevel=INFO --schedule="$STACK_DIR/var/celerybeat-schedule" ;;
    agent) start agent env UPLINK_SERVER_URL="wss://localhost:$HTTPS_PORT/uplink/" \
             UPLINK_CREDENTIAL_FILE="$STACK_DIR/uplink-credential" UPLINK_CA_FILE="$STACK_DIR/tls/fullchain.pem" \
             UPLINK_ROSBRIDGE_URL="ws://127.0.0.1:$SIM_PORT" UPLINK_VIDEO_URL="http://127.0.0.1:$VIDEO_PORT" \
             "$BIN/python" -m uplink_agent ;;
    nginx) start nginx "$NGINX" -e "$LOGS/nginx-error.log" -p "$STACK_DIR/nginx" -c "$STACK_DIR/nginx/nginx.conf" \
             -g "daemon off;" ;;
    *) say "no process called $1 (one of: $(names | tr '\n' ' '))"; exit 2 ;;
  esac
}

# Stop the named processes (SIGTERM, then SIGKILL after 10 s) and forget their pid files.
stop() {
  local name pid
  for name in "$@"; do
    [[ -f $PIDS/$name.pid ]] || continue
    pid=$(<"$PIDS/$name.pid")
    if ours "$pid"; then kill -TERM -- "-$pid" 2>/dev/null || kill -TERM "$pid" 2>/dev/null || true; fi
  done
  for name in "$@"; do
    [[ -f $PIDS/$name.pid ]] || continue
    pid=$(<"$PIDS/$name.pid")
    for _ in $(seq 100); do ours "$pid" || break; sleep 0.1; done
    if ours "$pid"; then say "$name ($pid) ignored SIGTERM; killing it"; kill -KILL -- "-$pid" 2>/dev/null || true; fi
    rm -f "$PIDS/$name.pid" "$PIDS/$name.child"
  done
}

# pid: is it alive and one of this stack's processes? nginx rewrites its environment block, so its
# command line says (its own arguments, or the one-line title it writes over them). grep reads the
# files itself: behind a pipe, with pipefail, a writer that outlived grep -q's early exit (SIGPIPE)
# would make a live process look gone.
ours() {
  [[ -r /proc/$1/environ ]] || return 1
  grep -qzxF -- "CYBORG_STACK=$STACK_DIR" "/proc/$1/environ" 2>/dev/null \
    || grep -qzxF -- "$STACK_DIR/nginx" "/proc/$1/cmdline" 2>/dev/null \
    || grep -qzF -- "-p $STACK_DIR/nginx " "/proc/$1/cmdline" 2>/dev/null
}

create_database() {
  in_env "$BIN/python" - <<'EOF'
import os
import dj_database_url
import psycopg
from psycopg import sql

db = dj_database_url.parse(os.environ["DATABASE_URL"])
if db["ENGINE"].endswith("postgresql"):
    with psycopg.connect(host=db["HOST"] or None, port=db["PORT"] or None, user=db["USER"] or None,
                         password=db["PASSWORD"] or None, dbname="postgres", autocommit=True) as conn:
        if not conn.execute("SELECT 1 FROM pg_database WHERE datname = %s", [db["NAME"]]).fetchone():
            conn.execute(sql.SQL("CREATE DATABASE {}").format(sql.Identifier(db["NAME"])))
EOF
}

write_nginx() {
  local conf=$STACK_DIR/nginx user_line=""
  mkdir -p "$conf/tmp" "$STACK_DIR/tls"
  openssl req -x509 -newkey rsa:2048 -nodes -days 7 -subj "/CN=localhost" \
    -addext "subjectAltName=DNS:localhost,IP:127.0.0.1" \
    -keyout "$STACK_DIR/tls/privkey.pem" -out "$STACK_DIR/tls/fullchain.pem" 2>/dev/null
  # The shipped site, with local ports, name and paths (IPv6 listeners dropped: loopback only), and
  # HSTS as short as the environment's (a browser keeps it for localhost whatever the port).
  sed -e "s|listen 80;|listen 127.0.0.1:$HTTP_PORT;|" \
      -e "s|listen 443 ssl http2;|listen 127.0.0.1:$HTTPS_PORT ssl http2;|" \
      -e '/listen \[::\]/d' \
      -e "s|server_name cyborg.example.org;|server_name localhost;|" \
      -e "s|https://\$server_name\$request_uri|https://\$server_name:$HTTPS_PORT\$request_uri|" \
      -e '/Strict-Transport-Security/s|max-age=[0-9]*|max-age=60|' \
      -e "s|/etc/ssl/cyborg/|$STACK_DIR/tls/|" \
      -e "s|/srv/cyborg/staticfiles/|$STACK_DIR/var/staticfiles/|" \
      -e "s|server 127.0.0.1:8001 |server 127.0.0.1:$WEB_A |" \
      -e "s|server 127.0.0.1:8002 |server 127.0.0.1:$WEB_B |" \
      -e "s|server 127.0.0.1:8770 |server 127.0.0.1:$UPLINK_PORT |" \
      deploy/nginx/cyborg.conf >"$conf/site.conf"
  if [[ $(id -u) == 0 ]]; then user_line="user root;"; fi
  cat >"$conf/nginx.conf" <<EOF
$user_line
worker_processes 1;
pid $conf/nginx.pid;
error_log $LOGS/nginx-error.log warn;
events { worker_connections 1024; }
http {
    include /etc/nginx/mime.types;
    default_type application/octet-stream;
    sendfile on;
    access_log $LOGS/nginx-access.log;
    client_body_temp_path $conf/tmp/body;
    proxy_temp_path $conf/tmp/proxy;
    fastcgi_temp_path $conf/tmp/fastcgi;
    uwsgi_temp_path $conf/tmp/uwsgi;
    scgi_temp_path $conf/tmp/scgi;
    include $conf/site.conf;
}
EOF
  "$NGINX" -t -q -e "$LOGS/nginx-error.log" -p "$conf" -c "$conf/nginx.conf"
}

up() {
  [[ -x $BIN/python ]] || { say "run 'make install' first"; exit 1; }
  [[ -x $NGINX ]] || { say "nginx is missing: run 'make nginx' (Debian's nginx package)"; exit 1; }
  if [[ -d $PIDS ]] && ls "$PIDS"/*.pid >/dev/null 2>&1; then say "already up in $STACK_DIR (run down first)"; exit 1; fi
  mkdir -p "$PIDS" "$LOGS" "$STACK_DIR/var"
  write_env
  create_database
  # It gets the first admin's password (bootstrap).
  touch "$LOGS/setup.log" && chmod 600 "$LOGS/setup.log"
  # Static files first: with hashed names every page (and start-up code rendering one) needs the manifest.
  in_env "$BIN/python" manage.py collectstatic --noinput >>"$LOGS/setup.log"
  in_env "$BIN/python" manage.py migrate --noinput >>"$LOGS/setup.log"
  in_env "$BIN/python" manage.py bootstrap >>"$LOGS/setup.log"
  if [[ -n "${STACK_UPLINK:-}" ]]; then  # the robot's credential, as an admin would make it
    install -m 600 /dev/null "$STACK_DIR/uplink-credential"
    in_env "$BIN/python" manage.py shell -c "from robot.uplink.credentials import credential_create
print(credential_create(robot='cyborg', label='stack.sh')[1])" | tail -n 1 >"$STACK_DIR/uplink-credential"
  fi
  write_nginx
  for name in $(names); do launch "$name"; done
  if [[ -z "${ROSBRIDGE_URL:-}" ]]; then wait_port "$SIM_PORT" 30 simulator; fi
  wait_port "$WEB_A" 60 web-a
  wait_port "$WEB_B" 60 web-b
  wait_port "$HTTPS_PORT" 10 nginx
  local deadline=$((SECONDS + 60))
  until curl -skf "https://127.0.0.1:$HTTPS_PORT/healthz" | grep -q '"connected": true'; do
    if ((SECONDS >= deadline)); then say "the robot never came online through nginx; see $LOGS/"; exit 1; fi
    sleep 0.2
  done
  say "up: https://localhost:$HTTPS_PORT/  (self-signed certificate; first admin in $LOGS/setup.log)"
}

down() {
  [[ -d $PIDS ]] || { say "nothing to stop in $STACK_DIR"; return 0; }
  # The front first (no new work), the links last (they release the lease and flush history).
  stop agent nginx web-a web-b beat worker link-b link-a sim
  say "down"
}

# Rolling restarts, and bringing back a process a test killed: stop (if running) and start again.
restart() {
  local name
  [[ -f $ENV_FILE ]] || { say "not up in $STACK_DIR"; exit 1; }
  for name in "$@"; do
    stop "$name"
    launch "$name"
    case $name in
      web-a) wait_port "$WEB_A" 60 web-a ;;
      web-b) wait_port "$WEB_B" 60 web-b ;;
      sim) wait_port "$SIM_PORT" 30 simulator ;;
      nginx) wait_port "$HTTPS_PORT" 10 nginx ;;
    esac
  done
}

status() {
  local pidfile name
  for pidfile in "$PIDS"/*.pid; do
    [[ -f $pidfile ]] || continue
    name=$(basename "$pidfile" .pid)
    if ours "$(<"$pidfile")"; then echo "$name: running ($(<"$pidfile"))"; else echo "$name: dead"; fi
  done
}

case "${1:-}" in
  up) up ;;
  down) down ;;
  status) status ;;
  restart) shift; restart "$@" ;;
  *) echo "usage: $0 up|down|status|restart NAME..." >&2; exit 2 ;;
esac
