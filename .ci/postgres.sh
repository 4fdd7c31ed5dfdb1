#!/usr/bin/env bash
# A throwaway PostgreSQL server for the history tests (docs/history.md, "Testing against PostgreSQL"): Debian's
# server (installed when missing and run as root), a data directory under /tmp, a loopback port, trust
# authentication for the local user, no fsync. The server refuses to run as root: as root it runs as `postgres`.
#
#   eval "$(bash .ci/postgres.sh)"        start (or find running) and export RIG_TEST_POSTGRES_URL
#   bash .ci/postgres.sh stop             stop it and remove its data directory
#
# RIG_PG_PORT (default 54329) and RIG_PG_DIR (default /tmp/rig-postgres-PORT) choose another one.
set -euo pipefail
PORT="${RIG_PG_PORT:-54329}"
DATA="${RIG_PG_DIR:-/tmp/rig-postgres-$PORT}"
BIN="$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -1 || true)"
if [ -z "$BIN" ]; then
  if [ "$(id -u)" = 0 ]; then
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq postgresql >/dev/null) >&2
    BIN="$(ls -d /usr/lib/postgresql/*/bin | sort -V | tail -1)"
  else
    echo "postgres.sh: no PostgreSQL server installed (apt-get install postgresql)" >&2
    exit 1
  fi
fi
if [ "$(id -u)" = 0 ]; then
  USER_NAME=postgres
  as_user() { runuser -u postgres -- "$@"; }
else
  USER_NAME="$(id -un)"
  as_user() { "$@"; }
fi
if [ "${1:-start}" = stop ]; then
  if [ -f "$DATA/PG_VERSION" ]; then as_user "$BIN/pg_ctl" -D "$DATA" -m fast -w stop >&2 || true; fi
  rm -rf "$DATA"
  exit 0
fi
if [ ! -f "$DATA/PG_VERSION" ]; then
  mkdir -p "$DATA"
  chmod 700 "$DATA"
  [ "$(id -u)" = 0 ] && chown postgres: "$DATA"
  as_user "$BIN/initdb" -D "$DATA" -U "$USER_NAME" -A trust --no-sync -E UTF8 >/dev/null
fi
if ! as_user "$BIN/pg_ctl" -D "$DATA" status >/dev/null 2>&1; then
  if ! as_user "$BIN/pg_ctl" -D "$DATA" -l "$DATA/server.log" -w -t 30 \
      -o "-p $PORT -k $DATA -c listen_addresses=127.0.0.1 -c fsync=off -c max_connections=100" start >&2; then
    echo "postgres.sh: the server did not start on 127.0.0.1:$PORT: $( (grep -E "FATAL|ERROR|PANIC" "$DATA/server.log" || tail -n 1 "$DATA/server.log") 2>/dev/null | tail -n 1)" >&2
    exit 1
  fi
fi
echo "export RIG_TEST_POSTGRES_URL=postgresql+psycopg://$USER_NAME@127.0.0.1:$PORT/postgres"
