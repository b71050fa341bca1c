#!/usr/bin/env bash
# Installs the system packages the test suite needs (headless Chromium for the report test).
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
