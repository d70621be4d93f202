#!/usr/bin/env bash
# Set up a fresh Debian machine for one level of work, installing only what that level needs:
#   scripts/setup.sh run    what `make run` needs: a race (Debian's [run] packages, .venv with the
#                           simulator: pip install -e '.[sim]')
#   scripts/setup.sh test   what `make test` needs: everything ([run] and [test] packages, the
#                           MicroPython runtime from npm, .venv with every extra: '.[dev]')
# Missing apt packages are installed when root. Re-running is cheap: each step is skipped when done.
set -euo pipefail
cd "$(dirname "$0")/.."
level=${1:-test}
case $level in run | test) ;; *) echo "setup: level must be run or test, got $level" >&2; exit 2 ;; esac

apt_install() {  # the given Debian packages, as root
  if [[ $(id -u) -eq 0 ]] && command -v apt-get >/dev/null; then
    echo "setup: installing Debian packages: $*"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$@" >/dev/null
  else
    echo "setup: missing Debian packages (install them as root): $*" >&2
  fi
}

missing=() section=""
while read -r line; do
  [[ -z "$line" || "$line" == \#* ]] && continue
  if [[ "$line" == \[*\] ]]; then section=${line:1:-1}; continue; fi
  [[ $section == run || $level == test ]] || continue
  dpkg-query -W -f='${Status}' "$line" 2>/dev/null | grep -q "install ok installed" || missing+=("$line")
done < scripts/apt-packages.txt
if ((${#missing[@]})); then apt_install "${missing[@]}"; fi

if [[ $level == test ]]; then
  # Node.js runs the official MicroPython WebAssembly runtime for the MicroPython tests. Any
  # Node.js >= 18 will do (Debian's, or one already installed from elsewhere, with its own npm).
  if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
    apt_install nodejs npm
  fi
  # and an independent Foxglove WebSocket client (npm @foxglove/ws-protocol) for the live-server tests
  for runner in hil_sim/micropython tests/foxglove_client; do
    if command -v npm >/dev/null && [[ ! -f $runner/node_modules/.installed || $runner/package-lock.json -nt $runner/node_modules/.installed ]]; then
      echo "setup: npm ci in $runner"
      (cd "$runner" && npm ci --no-audit --no-fund --loglevel=error >/dev/null) && touch "$runner/node_modules/.installed"
    fi
  done
fi

# .venv with the pinned dependencies of the level; the test level's includes the run level's.
PY=${PYTHON:-python3}
extras=$([[ $level == run ]] && echo sim || echo dev)
stamp=.venv/.installed-$level
fresh() { [[ -f $1 && ! pyproject.toml -nt $1 ]]; }
if [[ ! -x .venv/bin/python ]] || ! { fresh "$stamp" || { [[ $level == run ]] && fresh .venv/.installed-test; }; }; then
  echo "setup: .venv with the pinned dependencies ($extras)"
  [[ -x .venv/bin/python ]] || "$PY" -m venv .venv
  log=.venv/pip.log
  if [[ $level == test ]] && ! .venv/bin/python -c "import torch" 2>/dev/null; then
    # PyTorch's CPU build (PPO's example and test): a wheel this machine keeps (pip's find-links),
    # else PyTorch's CPU index; failing both, the pip install below takes PyPI's (CUDA) build
    torch=$(sed -n 's/.*"\(torch==[^"]*\)".*/\1/p' pyproject.toml)
    .venv/bin/python -m pip install --disable-pip-version-check --no-deps --no-index "$torch" >"$log" 2>&1 ||
      .venv/bin/python -m pip install --disable-pip-version-check --no-deps --timeout 30 "$torch" \
        --index-url https://download.pytorch.org/whl/cpu >>"$log" 2>&1 || true
  fi
  if ! .venv/bin/python -m pip install --disable-pip-version-check -e ".[$extras]" >"$log" 2>&1; then
    echo "setup: pip install failed; last lines of $log:" >&2
    tail -n 15 "$log" >&2
    exit 1
  fi
  touch "$stamp"
fi

# The ROS 2 message types no wheel has (roar.ros2.interfaces), built into .venv: once, and again
# when their definitions change
if [[ $level == test ]] && .venv/bin/python -c "import rclpy" 2>/dev/null; then
  built=$(.venv/bin/python -m roar.ros2.interfaces 2>&1) ||
    { echo "$built" >&2; echo "setup: the ROS 2 message types did not build" >&2; exit 1; }
  grep -v ": current$" <<<"$built" || true
fi

# A ROS 2 user's node on an older distribution (Jazzy) in a side environment, to check that it and
# our Kilted node work together. Not fatal: where it cannot install, that test skips and says why.
if [[ $level == test ]]; then
  side=.venv-ros2-jazzy
  if [[ ! -f $side/.installed || tests/ros2/jazzy-requirements.txt -nt $side/.installed ]]; then
    if command -v python3.11 >/dev/null; then
      echo "setup: $side (a ROS 2 Jazzy node's environment)"
      { [[ -x $side/bin/python ]] || python3.11 -m venv "$side"; } &&
        $side/bin/python -m pip install --disable-pip-version-check -r tests/ros2/jazzy-requirements.txt \
          >"$side.log" 2>&1 &&
        .venv/bin/python -m roar.ros2.interfaces --prefix "$side" >>"$side.log" 2>&1 && touch "$side/.installed" ||
        echo "setup: ROS 2 Jazzy did not install (see $side.log): its test will skip" >&2
    else
      echo "setup: no python3.11 for a ROS 2 Jazzy node: its test will skip" >&2
    fi
  fi
fi

# DonkeyCar's own tub reader in a side environment (it wants Python 3.11 and numpy < 2), to check
# the tubs `roar dataset` writes. Not fatal: where it cannot install, that test skips and says why.
if [[ $level == test ]]; then
  side=.venv-donkey
  if [[ ! -f $side/.installed || tests/donkey/requirements.txt -nt $side/.installed ]]; then
    if command -v python3.11 >/dev/null; then
      echo "setup: $side (DonkeyCar's tub reader)"
      { [[ -x $side/bin/python ]] || python3.11 -m venv "$side"; } &&
        $side/bin/python -m pip install --disable-pip-version-check -r tests/donkey/requirements.txt \
          >"$side.log" 2>&1 && touch "$side/.installed" ||
        echo "setup: DonkeyCar did not install (see $side.log): its tub test will skip" >&2
    else
      echo "setup: no python3.11 for DonkeyCar's tub reader: its tub test will skip" >&2
    fi
  fi
fi

# Numba's kernels into its disk cache. For a race the simulated camera's (~8 s the first time): a
# car's first frame then takes ~0.7 s, not a stall of a real-time loop (a phone's stream, roar web).
# For the suite every kernel (scripts/warm_kernels.py: ~45 s the first time, again when a module
# holding a kernel changes, as Numba's cache does), so that no worker compiles one on first use.
warmed=.venv/.numba-warm
if [[ $level == run ]]; then
  .venv/bin/python -c "from roar_sim.world.ray_camera import warm; warm()" ||
    { echo "setup: the simulated camera's kernels did not compile" >&2; exit 1; }
elif [[ ! -f $warmed || -n $(find host hil_sim -name '*.py' -newer "$warmed" -exec grep -l 'njit' {} +) ]]; then
  echo "setup: compiling Numba's kernels (scripts/warm_kernels.py)"
  .venv/bin/python scripts/warm_kernels.py && touch "$warmed" ||
    { echo "setup: Numba's kernels did not compile (scripts/warm_kernels.py says why)" >&2; exit 1; }
fi
# The native programs the suite runs (the core for this machine in each variant, the fuzz targets),
# built where stale, so that no worker builds one on first use (scripts/build_ahead.py).
if [[ $level == test ]]; then
  .venv/bin/python scripts/build_ahead.py ||
    { echo "setup: a native build failed (scripts/build_ahead.py says why)" >&2; exit 1; }
fi
