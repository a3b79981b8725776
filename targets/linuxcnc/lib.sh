# Shared by run.sh and sim.sh (sourced): the RTAPI environment, a free realtime, installing a
# component. Every workaround here is explained in README.md, "Environment".

REALTIME=/usr/lib/linuxcnc/realtime

die() { echo "$(basename "$0"): $*" >&2; exit 2; }

# Root: rtapi_app refuses to run as root unless RTAPI_UID names a non-root uid; it then keeps
# euid 0 but does its file access as that uid (setfsuid). So its socket RTAPI_FIFO_PATH
# (default $HOME/.rtapi_fifo; /root is not writable by that uid) goes to a directory that uid
# owns, and the installed module must be readable by it (umask 022, chmod 644).
# Sets SUDO for the commands that need root.
qloop_rtapi_env() {
    umask 022
    if [ "$(id -u)" = 0 ]; then
        export RTAPI_UID=${RTAPI_UID:-65534}
        [ "$RTAPI_UID" != 0 ] || die "RTAPI_UID must not be 0"
        if [ -z "${RTAPI_FIFO_PATH:-}" ]; then
            # A fixed path, so that a session left by a killed run can be stopped by the next.
            local dir=/tmp/qloop-rtapi
            [ ! -L "$dir" ] || die "$dir is a symlink"
            mkdir -p "$dir"
            chown "$RTAPI_UID" "$dir"
            chmod 700 "$dir"
            export RTAPI_FIFO_PATH=$dir/rtapi_fifo
        fi
        SUDO=
    else
        SUDO=sudo
        command -v sudo >/dev/null || die "halcompile --install needs root (or sudo)"
    fi
}

# Refuse to start while another realtime session runs (HAL shared memory is machine-wide),
# unless QLOOP_HALRUN_CLEANUP=1; then remove SysV segments a crashed rtapi_app left behind
# (`halrun -U` removes only the HAL, RTAPI and UUID keys, not streamer/sampler ones, and a
# stale one of another size makes `loadrt streamer`/`sampler` fail with EINVAL).
qloop_realtime_free() {
    if "$REALTIME" status >/dev/null 2>&1; then
        [ "${QLOOP_HALRUN_CLEANUP:-0}" = 1 ] \
            || die "a LinuxCNC realtime session (rtapi_app) is already running; stop it with 'halrun -U' (with its RTAPI_FIFO_PATH; for one left by run.sh/sim.sh: ${RTAPI_FIFO_PATH:-\$HOME/.rtapi_fifo}) or rerun with QLOOP_HALRUN_CLEANUP=1"
        echo "$(basename "$0"): stopping the running LinuxCNC realtime session (halrun -U)" >&2
        halrun -U >/dev/null 2>&1 || true
        ! "$REALTIME" status >/dev/null 2>&1 \
            || die "could not stop the running realtime session (started with another RTAPI_FIFO_PATH?)"
    fi
    if command -v ipcs >/dev/null; then
        local key
        for key in $(ipcs -m | awk '$6 == 0 && tolower($1) ~ /^0x(48414c32|48484c34|90280a48|4853543[0-7]|4853413[0-7])$/ {print $1}'); do
            echo "$(basename "$0"): removing stale HAL shared memory segment $key" >&2
            $SUDO ipcrm -M "$key" || true
        done
    fi
}

# qloop_install COMPFILE LOG: halcompile --install, made readable by RTAPI_UID.
qloop_install() {
    local comp=$1 log=$2 name moddir
    name=$(basename "$comp" .comp)
    (cd "$(dirname "$log")" && $SUDO halcompile --install "$comp") > "$log" 2>&1 \
        || { cat "$log" >&2; die "halcompile --install $comp failed"; }
    sed 's/^/   /' "$log"
    # `cp` keeps the mode of an existing file and uses the umask for a new one: make sure
    # RTAPI_UID can read the module (else: "dlopen: ... Permission denied").
    moddir=$(sed -n "s|^cp $name\\.so \\(.*\\)/\$|\\1|p" "$log" | tail -1)
    [ -n "$moddir" ] && [ -f "$moddir/$name.so" ] || die "installed module not found (halcompile output above)"
    $SUDO chmod 644 "$moddir/$name.so"
}
