#!/usr/bin/env bash
# Runs inside `unshare --user --map-root-user --net` (no real root needed): makes a veth pair,
# attaches the simulated drive(s) to one end with the documented command, and runs the SOEM
# (pysoem) scenario on the other end. Everything vanishes with the namespace.
#
# Environment: PYTHON (venv python with pysoem), WORKSPACE, PROFILE, DRIVES, SIM_LOG, RESULT.
set -euo pipefail
ip link set lo up
ip link add ecm0 type veth peer name ecs0
ip link set ecm0 up
ip link set ecs0 up
# IPv6 router/neighbour traffic would otherwise show up on the wire.
sysctl -qw net.ipv6.conf.ecm0.disable_ipv6=1 net.ipv6.conf.ecs0.disable_ipv6=1 2>/dev/null || true
# A veth end reports carrier only some time after both ends are up; frames sent before are lost.
for _ in $(seq 1 100); do
    [ "$(cat /sys/class/net/ecm0/carrier 2>/dev/null)" = 1 ] && [ "$(cat /sys/class/net/ecs0/carrier 2>/dev/null)" = 1 ] && break
    sleep 0.02
done

cd "$WORKSPACE"
# The command the README documents for attaching a simulated drive to an interface.
cargo run --release -q -p board-sim -- attach --iface ecs0 --profile "$PROFILE" --drives "$DRIVES" --seconds 120 >"$SIM_LOG" 2>&1 &
sim=$!
trap 'kill -INT $sim 2>/dev/null || true; wait $sim 2>/dev/null || true' EXIT
for _ in $(seq 1 200); do
    grep -q "waiting for a master" "$SIM_LOG" 2>/dev/null && break
    kill -0 $sim 2>/dev/null || { echo "sim-drive exited early:"; cat "$SIM_LOG"; exit 3; }
    sleep 0.05
done
"$PYTHON" "$WORKSPACE/tests-host/soem/scenario.py" ecm0 "$DRIVES" >"$RESULT"
