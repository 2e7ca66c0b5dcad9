# Sourced by scripts/run and scripts/test: installs the Debian packages sid needs, if missing.
SID_PACKAGES=(cmake g++ make libeigen3-dev libsundials-dev libnlopt-dev libgtest-dev libbenchmark-dev
              libcli11-dev nlohmann-json3-dev libyaml-cpp-dev gnuplot-nox)

# Extra packages a caller needs beyond SID_PACKAGES are given as arguments.
sid_install_missing_packages() {
  local missing=()
  for pkg in "${SID_PACKAGES[@]}" "$@"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q 'install ok installed' \
      || missing+=("$pkg")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "sid: installing missing packages: ${missing[*]}"
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

sid_jobs() { nproc 2>/dev/null || echo 2; }

# Builds the Python package into a virtual environment under build/ and runs its tests.
# $1: a build directory of this checkout whose libraries the extension links (its apps are the
# CLI the tests compare with); the package is otherwise built as `pip install .` builds it.
sid_python_package() {
  local root build venv
  root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
  build=$1
  venv="$root/build/python-venv"
  [ -x "$venv/bin/python" ] || python3 -m venv "$venv"
  SID_PYTHON_PREBUILT="$build" "$venv/bin/python" -m pip install --quiet --disable-pip-version-check \
    --config-settings=build-dir="$root/build/python" "$root[test]"
  (cd "$root" && SID_APPS_DIR="$build/apps" "$venv/bin/python" -m pytest -q python/tests)
}
