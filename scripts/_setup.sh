#!/usr/bin/env bash
# Shared set-up for ./scripts/demo and ./scripts/test; sourced, not run.
# Installs what is missing (system packages, .venv, the package in editable mode) and nothing else,
# so a second run costs a few seconds.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
PY="${PYTHON:-python3}"

# System libraries: ODE for physics, EGL + Mesa for headless GL, Xvfb/xauth for window tests.
SYSTEM_PACKAGES=(libode8 libegl1 libegl-mesa0 libgl1-mesa-dri libgl1 xvfb xauth)

missing_system_packages() {
    local pkg missing=()
    for pkg in "${SYSTEM_PACKAGES[@]}"; do
        if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
            missing+=("$pkg")
        fi
    done
    echo "${missing[@]:-}"
}

ensure_system_packages() {
    if ! command -v dpkg-query >/dev/null 2>&1; then
        echo "dentdemo: not a Debian system; make sure these are installed: ${SYSTEM_PACKAGES[*]}" >&2
        return 0
    fi
    local missing
    missing="$(missing_system_packages)"
    [[ -z "$missing" ]] && return 0
    local line="apt-get update && apt-get install -y $missing"
    if [[ "$(id -u)" == "0" ]]; then
        echo "dentdemo: installing system packages: $missing"
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $missing >/dev/null
    elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
        echo "dentdemo: installing system packages with sudo: $missing"
        sudo -n apt-get update -qq
        sudo -n env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $missing >/dev/null
    else
        echo "dentdemo: missing system packages; run as root:  $line" >&2
        exit 1
    fi
}

ensure_venv() {
    if [[ ! -x "$VENV/bin/python" ]]; then
        echo "dentdemo: creating $VENV"
        "$PY" -m venv "$VENV"
    fi
    # Reinstall only when pyproject.toml changed since the last successful install.
    local stamp="$VENV/.dentdemo-installed" want
    want="$(sha256sum "$ROOT/pyproject.toml" | cut -d' ' -f1)"
    if [[ ! -f "$stamp" || "$(cat "$stamp")" != "$want" ]]; then
        echo "dentdemo: installing the package, its app extra and its test tools into .venv"
        local log="$VENV/pip-install.log"
        # pip 21.3 installs a pyproject.toml project editable; a venv's own pip is older
        # only on old Pythons, and upgrading it costs a fresh clone several seconds.
        if ! { "$VENV/bin/python" -c 'import pip, sys; sys.exit(int(pip.__version__.split(".")[0]) < 22)' ||
               "$VENV/bin/python" -m pip install -q --upgrade pip; } >"$log" 2>&1 ||
           ! "$VENV/bin/python" -m pip install -q -e "$ROOT[app,test]" >>"$log" 2>&1; then
            tail -n 30 "$log" >&2
            echo "dentdemo: pip install failed (full log: $log)" >&2
            exit 1
        fi
        echo "$want" >"$stamp"
    fi
}

# Node tools the tests use, in the git-ignored .tools/node: the Khronos glTF validator.
NODE_TOOLS="$ROOT/.tools/node"
NODE_PACKAGES=("gltf-validator@2.0.0-dev.3.10")

ensure_node_tools() {
    if ! command -v npm >/dev/null 2>&1; then
        echo "dentdemo: npm not found: the glTF validator tests will be skipped" \
            "(Debian: apt-get install nodejs npm)" >&2
        return 0
    fi
    local stamp="$NODE_TOOLS/.installed" want="${NODE_PACKAGES[*]}"
    [[ -f "$stamp" && "$(cat "$stamp")" == "$want" ]] && return 0
    echo "dentdemo: installing $want into $NODE_TOOLS"
    mkdir -p "$NODE_TOOLS"
    local log="$NODE_TOOLS/npm-install.log"
    if ! npm install --prefix "$NODE_TOOLS" --no-audit --no-fund --no-save "${NODE_PACKAGES[@]}" \
        >"$log" 2>&1; then
        tail -n 30 "$log" >&2
        echo "dentdemo: npm install failed (full log: $log)" >&2
        exit 1
    fi
    echo "$want" >"$stamp"
}

ensure_system_packages
ensure_venv
ensure_node_tools
export PATH="$VENV/bin:$PATH"
