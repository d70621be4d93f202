#!/usr/bin/env bash
# Set up everything `make run` and `make test` need on a fresh Debian machine:
# missing apt packages (when root), then .venv with the pinned Python dependencies.
# Re-running is cheap: each step is skipped when already done.
set -euo pipefail
cd "$(dirname "$0")/.."

missing=()
while read -r pkg; do
  [[ -z "$pkg" || "$pkg" == \#* ]] && continue
  dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed" || missing+=("$pkg")
done < scripts/apt-packages.txt
if ((${#missing[@]})); then
  if [[ $(id -u) -eq 0 ]] && command -v apt-get >/dev/null; then
    echo "setup: installing Debian packages: ${missing[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "setup: missing Debian packages (install them as root): ${missing[*]}" >&2
  fi
fi

# Node.js runs the official MicroPython WebAssembly runtime for the MicroPython tests. Any
# Node.js >= 18 will do (Debian's, or one already installed from elsewhere, which then keeps
# its own npm).
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  if [[ $(id -u) -eq 0 ]] && command -v apt-get >/dev/null; then
    echo "setup: installing Debian packages: nodejs npm"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends nodejs npm >/dev/null
  else
    echo "setup: missing Node.js (install as root: apt-get install nodejs npm); MicroPython tests will skip" >&2
  fi
fi
runner=hil_sim/micropython
if command -v npm >/dev/null && [[ ! -f $runner/node_modules/.installed || $runner/package-lock.json -nt $runner/node_modules/.installed ]]; then
  echo "setup: installing the MicroPython runtime (npm ci in $runner)"
  (cd "$runner" && npm ci --no-audit --no-fund --loglevel=error >/dev/null) && touch "$runner/node_modules/.installed"
fi

PY=${PYTHON:-python3}
stamp=.venv/.installed
if [[ ! -x .venv/bin/python || ! -f $stamp || pyproject.toml -nt $stamp ]]; then
  echo "setup: creating .venv with the pinned dependencies"
  [[ -x .venv/bin/python ]] || "$PY" -m venv .venv
  log=.venv/pip.log
  if ! { .venv/bin/python -m pip install -e '.[dev]'; } >"$log" 2>&1; then
    echo "setup: pip install failed; last lines of $log:" >&2
    tail -n 15 "$log" >&2
    exit 1
  fi
  touch "$stamp"
fi
