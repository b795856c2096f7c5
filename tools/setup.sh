#!/usr/bin/env bash
# diffreg set-up: installs the Debian packages the project needs (idempotent), configures a
# Release build with CMake and builds it. Then, by sub-command:
#   tools/setup.sh demo   run the shipped demo scenario (the default)
#   tools/setup.sh test   run the whole test suite
#   tools/setup.sh build  only install and build
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
what="${1:-demo}"
case "$what" in
  demo | test | build) ;;
  *) echo "setup: unknown sub-command '$what' (use demo, test or build)" >&2; exit 2 ;;
esac

packages=(build-essential cmake pkg-config libopenmesh-dev libeigen3-dev libcgal-dev catch2
          libboost-program-options-dev libsuitesparse-dev libopenblas0-pthread libopenblas-pthread-dev nlohmann-json3-dev
          libpng-dev libpugixml-dev libtbb-dev tetgen doxygen libcpp-httplib-dev libjs-three
          python3-dev pybind11-dev python3-numpy python3-matplotlib libcairo2-dev fonts-dejavu-core)
# Only the tests need these: the browser test of diffreg serve, the fuzzers (clang's libFuzzer)
# and the Python tests.
[ "$what" = test ] && packages+=(chromium nodejs clang libclang-rt-14-dev python3-pytest)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# npm for the browser test (web/test); some Node.js builds bring their own.
[ "$what" = test ] && { command -v npm >/dev/null 2>&1 || missing+=(npm); }
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

build="${DIFFREG_BUILD_DIR:-$here/build}"
jobs="$(nproc 2>/dev/null || echo 2)"
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$jobs"

case "$what" in
  build) ;;
  demo) "$here/tools/demo.sh" "$build" ;;
  test)
    # playwright-core for the browser test of diffreg serve (web/test), once per lock file.
    if [ ! -f web/test/node_modules/.package-lock.json ] ||
       [ web/test/package-lock.json -nt web/test/node_modules/.package-lock.json ]; then
      (cd web/test && npm ci --no-audit --no-fund --loglevel=error) ||
        echo "setup: npm ci in web/test failed; the browser test will be skipped" >&2
    fi
    cd "$build" && ctest --output-on-failure -j "$jobs" ;;
esac
