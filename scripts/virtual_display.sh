# Sourced by the scripts that render without a screen (demo.sh, screenshots.sh):
# start_virtual_display installs Xvfb from Debian when it is missing (the
# engine's Mesa comes with it in .deps, see scripts/deps.sh), starts it on a
# free display number at 1280x720 and exports DISPLAY; it stops on exit.

start_virtual_display() {
  if ! command -v Xvfb >/dev/null 2>&1; then
    echo "virtual display: installing Xvfb (Debian package xvfb)" >&2
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo="sudo"
    $sudo apt-get update -qq >/dev/null
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq xvfb >/dev/null
  fi
  local number=90
  while [ -e "/tmp/.X11-unix/X$number" ] || [ -e "/tmp/.X$number-lock" ]; do
    number=$((number + 1))
  done
  Xvfb ":$number" -screen 0 1280x720x24 -nolisten tcp >/dev/null 2>&1 &
  VIRTUAL_DISPLAY_PID=$!
  trap 'kill "$VIRTUAL_DISPLAY_PID" 2>/dev/null || true' EXIT
  export DISPLAY=":$number"
  local waited=0
  until [ -e "/tmp/.X11-unix/X$number" ] || [ $waited -ge 50 ]; do
    sleep 0.1
    waited=$((waited + 1))
  done
}
