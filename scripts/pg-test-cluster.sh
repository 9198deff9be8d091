#!/usr/bin/env bash
# A throw-away PostgreSQL cluster for tests and benchmarks, on a free 127.0.0.1 port.
#   scripts/pg-test-cluster.sh start DIR   → initdb in DIR, start; prints the database URL
#   scripts/pg-test-cluster.sh stop DIR    → stop it and remove DIR
# PostgreSQL refuses to run as root: as root the server runs as the unprivileged `postgres`
# user (made by Debian's postgresql package). fsync is off (a test cluster: durability across
# an OS crash is not what the tests measure). Exit 77 when the server binaries are absent.
set -euo pipefail
cmd=${1:?start|stop}; dir=${2:?DIR}
bindir=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -1 || true)
as_pg() {
  if [ "$(id -u)" -eq 0 ]; then runuser -u postgres -- "$@"; else "$@"; fi
}
case $cmd in
start)
  if [ -z "$bindir" ] || [ ! -x "$bindir/initdb" ]; then
    echo "PostgreSQL server binaries not found (scripts/install-deps.sh installs postgresql-15)" >&2
    exit 77
  fi
  if [ "$(id -u)" -eq 0 ] && ! id postgres >/dev/null 2>&1; then
    echo "no 'postgres' user to run the server as (install postgresql-15)" >&2
    exit 77
  fi
  mkdir -p "$dir"
  chmod 755 "$dir"
  [ "$(id -u)" -eq 0 ] && chown postgres "$dir"
  port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
  as_pg "$bindir/initdb" -D "$dir/data" -U matfit --auth=trust -E UTF8 --no-sync >"$dir/initdb.log" 2>&1 ||
    { cat "$dir/initdb.log" >&2; exit 1; }
  as_pg "$bindir/pg_ctl" -D "$dir/data" -l "$dir/server.log" -w -t 60 \
    -o "-p $port -k $dir -c listen_addresses=127.0.0.1 -c fsync=off -c max_connections=200" \
    start >/dev/null || { cat "$dir/server.log" >&2; exit 1; }
  echo "postgresql://matfit@127.0.0.1:$port/postgres"
  ;;
stop)
  if [ -n "$bindir" ] && [ -d "$dir/data" ]; then
    as_pg "$bindir/pg_ctl" -D "$dir/data" -m immediate -w stop >/dev/null 2>&1 || true
  fi
  rm -rf "$dir"
  ;;
*) echo "usage: $0 start|stop DIR" >&2; exit 2 ;;
esac
