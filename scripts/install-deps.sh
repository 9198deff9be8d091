#!/usr/bin/env bash
# Installs every Debian 12 package matfit needs to build, test and run.
# Idempotent: when everything is already installed it only runs dpkg-query (< 1 s).
# Usage: sudo scripts/install-deps.sh   (run as root; CI runs it from .ci/run)
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config ccache clang-format git nodejs
  # core: image I/O (JPEG, PNG and OpenEXR directly; OpenImageIO as a module for the other
  # formats), JSON, CLI, logging, threading, math
  libjpeg-dev libpng-dev libopenexr-dev libopenimageio-dev openimageio-tools nlohmann-json3-dev
  libcli11-dev
  libspdlog-dev libfmt-dev libtbb-dev libeigen3-dev libglm-dev
  # fuzzing and the sanitizer test job (build-san/): clang, libFuzzer + ASan/UBSan runtimes
  clang libclang-rt-14-dev
  # tests and benchmarks (time: /usr/bin/time for peak RSS and python3 for the tables of
  # scripts/bench-whole-process.sh)
  libgtest-dev libgmock-dev libbenchmark-dev time python3
  # fit: nonlinear least squares, image processing
  libceres-dev libopencv-core-dev libopencv-imgproc-dev
  # server: HTTP, job store, upload archives (curl: the shell tests and the README session)
  libcpp-httplib-dev libsqlite3-dev libarchive-dev curl
  # server cluster (issue 18): the PostgreSQL job store (libpqxx), and the server itself for its
  # tests (each starts a throw-away cluster as the unprivileged postgres user)
  libpqxx-dev postgresql-15
  # distributed fit (issue 18): OpenMPI, `mpirun … matfit fit` (tests/app/mpi_fit_test.sh)
  libopenmpi-dev openmpi-bin
  # server: SHA-256 of the tokens a cluster keeps in its database (OpenSSL's libcrypto)
  libssl-dev
  # server tests: hand-made PNG headers (zlib)
  zlib1g-dev
  # material packs: zip archives
  libzip-dev
  # render: headless EGL + GLES (Mesa llvmpipe)
  libegl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri
  # render: the WebGL2 viewer test runs in headless Chromium
  chromium
  # capture: USB light rigs, V4L2 cameras
  libusb-1.0-0-dev linux-libc-dev
  # bench: PNG copies of the SVG charts
  librsvg2-bin
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed'; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: missing packages: ${missing[*]}" >&2
  echo "install-deps: run this script as root (sudo $0) to install them" >&2
  exit 1
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install-deps: done"
