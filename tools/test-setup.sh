#!/usr/bin/env bash
# Installs the system packages the test suite needs (headless Chromium for the report test,
# LinuxCNC's rs274 for the post-processor).
# Idempotent; quiet when everything is already there.
set -euo pipefail
if ! command -v chromium >/dev/null 2>&1; then
    if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "test-setup: installing Debian's chromium for the report screenshot test"
        apt-get update -qq >/dev/null
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
    else
        echo "test-setup: chromium missing and cannot be installed here; the screenshot test will skip"
    fi
fi
# LinuxCNC's G-code interpreter (rs274) checks the LinuxCNC posts (tests/test_machines_rs274.py).
if ! command -v rs274 >/dev/null 2>&1; then
    if [ "$(id -u)" -eq 0 ] && command -v apt-get >/dev/null 2>&1; then
        echo "test-setup: installing Debian's linuxcnc-uspace for rs274 (LinuxCNC's interpreter)"
        apt-get update -qq >/dev/null || true
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
            linuxcnc-uspace >/dev/null 2>&1 \
            || echo "test-setup: linuxcnc-uspace could not be installed; the rs274 tests will skip"
    else
        echo "test-setup: rs274 missing and cannot be installed here; the rs274 tests will skip"
    fi
fi
