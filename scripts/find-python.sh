#!/usr/bin/env bash
# Prints the path of a Python 3.12 or newer for the server's virtual environment, or says how to get one.
for candidate in "${PY:-}" python3.12 python3.13 python3 \
    "$HOME"/.pyenv/versions/3.12*/bin/python3 "$HOME"/.pyenv/versions/3.13*/bin/python3; do
  [ -n "$candidate" ] || continue
  path=$(command -v "$candidate" 2>/dev/null) || continue
  if "$path" -c 'import sys; sys.exit(sys.version_info < (3, 12))' 2>/dev/null; then
    "$path" -c 'import sys; print(sys.executable)'
    exit 0
  fi
done
echo "Cyborg Commander's server needs Python 3.12 or newer, and none was found." >&2
echo "Install one (Debian/Ubuntu: apt-get install python3.12-venv; or pyenv install 3.12) and run again, or name it: make PY=/path/to/python3.12 ..." >&2
exit 1
