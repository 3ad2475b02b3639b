#!/usr/bin/env bash
# Runs inside `unshare --user --map-root-user --net` (no real root needed): makes a veth pair,
# attaches the simulated drive(s) to one end with the documented command, and runs the SOEM
# (pysoem) scenario on the other end (arguments: the master's interface, DRIVES and PROFILE).
# Everything vanishes with the namespace.
#
# Environment: PYTHON (venv python with pysoem), WORKSPACE, SCRIPT (in tests-host/soem),
# SIM_ARGS (extra sim-drive attach arguments), PROFILE (empty: drives from SIM_ARGS), DRIVES,
# SIM_LOG, RESULT.
set -euo pipefail
ip link set lo up
ip link add ecm0 type veth peer name ecs0
ip link set ecm0 up
ip link set ecs0 up
# IPv6 router/neighbour traffic would otherwise show up on the wire.
sysctl -qw net.ipv6.conf.ecm0.disable_ipv6=1 net.ipv6.conf.ecs0.disable_ipv6=1 2>/dev/null || true
# A veth end reports carrier (LOWER_UP) only some time after both ends are up; frames sent before
# are lost. (`ip`, not /sys/class/net: /sys still shows the parent namespace's interfaces.)
for _ in $(seq 1 100); do
    ip -o link show ecm0 | grep -q LOWER_UP && ip -o link show ecs0 | grep -q LOWER_UP && break
    sleep 0.02
done

cd "$WORKSPACE"
# The command the README documents for attaching a simulated drive to an interface.
# shellcheck disable=SC2086 # SIM_ARGS is a word list
# An empty PROFILE: the drives come from SIM_ARGS alone (a mixed line: --drive P --drive Q ...).
if [ -n "${PROFILE:-}" ]; then drive_args=(--profile "$PROFILE" --drives "$DRIVES"); else drive_args=(); fi
cargo run --release -q -p board-sim -- attach --iface ecs0 "${drive_args[@]}" --seconds 120 ${SIM_ARGS:-} >"$SIM_LOG" 2>&1 &
sim=$!
trap 'kill -INT $sim 2>/dev/null || true; wait $sim 2>/dev/null || true' EXIT
# `cargo run` may have to build first; wait for the simulator to listen (bounded), never start
# the master before it does.
ready=0
for _ in $(seq 1 6000); do
    if grep -q "waiting for a master" "$SIM_LOG" 2>/dev/null; then ready=1; break; fi
    kill -0 $sim 2>/dev/null || { echo "sim-drive exited early:"; cat "$SIM_LOG"; exit 3; }
    sleep 0.1
done
[ "$ready" = 1 ] || { echo "sim-drive did not come up within 600 s:"; cat "$SIM_LOG"; exit 3; }
"$PYTHON" "$WORKSPACE/tests-host/soem/${SCRIPT:-scenario.py}" ecm0 "$DRIVES" "${PROFILE:-}" >"$RESULT"
