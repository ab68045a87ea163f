#!/usr/bin/env bash
# The Python package's tests, on every CPython this machine has of those the suite names:
#
# 1. a venv under target/ for the default python3, with the pinned build backend and test tools
#    from PyPI (requirements.txt: maturin, pytest, NumPy, the `mcap` reader and `websockets` as
#    independent checks of the telemetry, mypy for the stubs); Debian's python3-venv from apt if
#    the interpreter lacks the venv module;
# 2. the wheel, once: `maturin build` of crates/rmd-py, one stripped abi3 wheel (cp39-abi3) for
#    every CPython >= 3.9, into target/python-wheels, with NumPy's wheel beside it so that a
#    test can install the package into a fresh venv offline;
# 3. the `rmd` tool, for the parity tests;
# 4. pytest on crates/rmd-py/tests with that wheel installed: in the python3 venv, then in a
#    venv of each other version in RMD_PYTHON_VERSIONS (default 3.9, the oldest the wheel is
#    for) that the machine has (python3.9 on PATH, under pyenv, /usr/bin or /usr/local/bin),
#    with requirements-<version>.txt where there is one. A version the machine does not have
#    is named on the way out: the suite did not run there.
#
# The wheel is built with cargo's dev profile (RMD_WHEEL_PROFILE, default dev) so that it reuses
# the workspace's debug build of everything but pyo3 and the package; `maturin build --release`
# (README) builds the same wheel optimised. Loopback only. Each venv is rebuilt only when its
# requirements file changes.
# Usage: ./tests/python/run.sh [pytest args...]
set -euo pipefail
cd "$(dirname "$0")/../.."
# shellcheck source=tests/workspace-build.sh
source tests/workspace-build.sh

target_dir="${CARGO_TARGET_DIR:-target}"
case "$target_dir" in /*) ;; *) target_dir="$PWD/$target_dir" ;; esac
wheels="$target_dir/python-wheels"
profile="${RMD_WHEEL_PROFILE:-dev}"
extra_versions="${RMD_PYTHON_VERSIONS-3.9}"

say() { echo "python tests: $*"; }

# The interpreter of CPython `$1` (3.9, ...) on this machine, if any.
find_python() {
  local version=$1 candidate
  for candidate in "$(command -v "python$version" || true)" \
    "${PYENV_ROOT:-$HOME/.pyenv}"/versions/"$version".*/bin/"python$version" \
    "/usr/local/bin/python$version" "/usr/bin/python$version"; do
    # A pyenv shim exists for every installed version but runs only the selected one.
    if [ -n "$candidate" ] && [ -x "$candidate" ] && "$candidate" -c "import sys" 2>/dev/null; then
      echo "$candidate"
      return 0
    fi
  done
  return 1
}

# A venv at `$2` for interpreter `$1` with the packages of requirements file `$3`, rebuilt when
# the file changes.
make_venv() {
  local python=$1 venv=$2 requirements=$3
  if [ -x "$venv/bin/python" ] && cmp -s "$requirements" "$venv/requirements.txt"; then
    return 0
  fi
  if ! "$python" -c "import ensurepip, venv" 2>/dev/null; then
    # Debian ships the venv module apart (python3-venv / python3.X-venv).
    local minor
    minor=$("$python" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
    say "installing python$minor-venv with apt"
    flock /tmp/rmd-apt.lock apt-get update -qq && flock /tmp/rmd-apt.lock apt-get install -y -qq "python$minor-venv" >/dev/null
  fi
  say "installing the pinned test tools ($requirements) into $venv"
  "$python" -m venv --clear "$venv"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-input \
    --requirement "$requirements"
  cp "$requirements" "$venv/requirements.txt"
}

main_venv="$target_dir/python-venv"
make_venv python3 "$main_venv" tests/python/requirements.txt

say "building the wheel (maturin, cargo profile $profile)"
rm -rf "$wheels"
(cd crates/rmd-py && PATH="$main_venv/bin:$PATH" maturin build --quiet --profile "$profile" \
  --out "$wheels")
wheel=$(echo "$wheels"/rmd_rt-*.whl)
test -f "$wheel"
say "built $(basename "$wheel") ($(du -k "$wheel" | cut -f1) KiB)"

cargo build --quiet "${RMD_WORKSPACE[@]}" --bins --examples
export RMD_BIN="$target_dir/debug/rmd"
test -x "$RMD_BIN"
export RMD_WHEEL="$wheel"

# Installs the wheel into venv `$1` and runs pytest there with the remaining arguments.
run_suite() {
  local venv=$1
  shift
  local numpy
  numpy=$("$venv/bin/python" -c "import numpy; print(numpy.__version__)")
  # The wheel and the NumPy it needs, for the test that installs them into a fresh venv.
  export RMD_WHEELHOUSE="$wheels/house-$("$venv/bin/python" -c \
    'import sys; print("%d.%d" % sys.version_info[:2])')"
  mkdir -p "$RMD_WHEELHOUSE"
  cp "$wheel" "$RMD_WHEELHOUSE/"
  "$venv/bin/python" -m pip download --quiet --disable-pip-version-check --no-input \
    --only-binary=:all: --no-deps --dest "$RMD_WHEELHOUSE" "numpy==$numpy"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-input \
    --no-deps --force-reinstall "$wheel"
  say "pytest on $("$venv/bin/python" --version)"
  (cd crates/rmd-py/tests && "$venv/bin/python" -m pytest -p no:cacheprovider -q . "$@")
}

run_suite "$main_venv" "$@"

missing=()
for version in $extra_versions; do
  if ! python=$(find_python "$version"); then
    missing+=("$version")
    continue
  fi
  requirements=tests/python/requirements-$version.txt
  [ -f "$requirements" ] || requirements=tests/python/requirements.txt
  venv="$target_dir/python-venv-$version"
  make_venv "$python" "$venv" "$requirements"
  run_suite "$venv" "$@"
done
if [ ${#missing[@]} -gt 0 ]; then
  say "NOT RUN on CPython ${missing[*]}: not on this machine (the suite ran on $(python3 --version) and the versions above)"
fi
