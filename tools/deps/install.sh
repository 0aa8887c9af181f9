#!/usr/bin/env bash
# Installs yamor's Debian packages and creates the Python venv (.venv).
# Idempotent and fast when everything is present; works as root or via sudo.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
pkgs=$(grep -v '^\s*#' "$root/tools/deps/debian-packages.txt" | grep -v '^\s*$')

missing=()
for p in $pkgs; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "deps: installing ${missing[*]}"
  if [ "$(id -u)" -eq 0 ]; then sudo=""; else sudo="sudo"; fi
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

venv="$root/.venv"
req="$root/tools/requirements.txt"
stamp="$venv/.requirements.sha256"
want=$(sha256sum "$req" | cut -d' ' -f1)
if [ ! -x "$venv/bin/python" ]; then
  echo "deps: creating $venv"
  python3 -m venv "$venv"
fi
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  echo "deps: installing Python requirements"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check -r "$req"
  echo "$want" > "$stamp"
fi

# The yamor package (tools/python: the client, the launcher and the tools with
# their yamor-* commands), editable so the checkout's code and stubs are what
# runs; installed again when its pyproject.toml (the commands) changed or the
# venv's yamor is another checkout's.
pyproject="$root/tools/python/pyproject.toml"
pkg_stamp="$venv/.yamor-pyproject.sha256"
pkg_want=$(sha256sum "$pyproject" | cut -d' ' -f1)
if [ ! -f "$pkg_stamp" ] || [ "$(cat "$pkg_stamp")" != "$pkg_want" ] || \
   ! "$venv/bin/python" -I -c 'import os, sys, yamor
sys.exit(os.path.dirname(os.path.dirname(os.path.realpath(yamor.__file__))) != os.path.realpath(sys.argv[1]))' \
    "$root/tools/python" 2>/dev/null; then
  echo "deps: installing the yamor Python package (tools/python)"
  "$venv/bin/python" -m pip install -q --disable-pip-version-check -e "$root/tools/python"
  echo "$pkg_want" > "$pkg_stamp"
fi
