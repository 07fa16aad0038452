"""A ground station made of pymavlink, against the link-only bench (`examples/link_bench.rs`).

Listens on an ephemeral UDP port on 127.0.0.1 (as QGroundControl listens on 14550), prints
`PORT <n>` so the test can point the bench's link at it, then waits for system 1's heartbeat,
fetches every parameter, and prints one JSON line: the heartbeat's fields and the parameters.
Exits 0 when both steps passed, 1 (with the step that failed) otherwise.
"""

import json
import sys
import time

from pymavlink import mavutil

mav = mavutil.mavlink
conn = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=255, source_component=190)
print("PORT", conn.port.getsockname()[1], flush=True)
results = {}


def fail(step, detail):
    print(json.dumps({"failed": step, "detail": str(detail), "results": results}), flush=True)
    sys.exit(1)


# 1. The vehicle's heartbeat (the bench has no vehicle: the link sends it alone).
deadline = time.monotonic() + 20
hb = None
while time.monotonic() < deadline and hb is None:
    msg = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
    if msg is not None and msg.get_srcSystem() == 1:
        hb = msg
if hb is None:
    fail("heartbeat", "none from system 1 within 20 s")
results["heartbeat"] = {
    "component": hb.get_srcComponent(),
    "type": mav.enums["MAV_TYPE"][hb.type].name,
    "autopilot": mav.enums["MAV_AUTOPILOT"][hb.autopilot].name,
}
conn.target_system, conn.target_component = 1, hb.get_srcComponent()

# 2. Every parameter, as a ground station fetches them on connecting.
conn.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
conn.mav.param_request_list_send(conn.target_system, conn.target_component)
params = {}
count = None
deadline = time.monotonic() + 10
while time.monotonic() < deadline and (count is None or len(params) < count):
    msg = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
    if msg is not None:
        params[msg.param_id] = msg.param_value
        count = msg.param_count
if count is None or len(params) < count:
    fail("params", f"{len(params)} of {count} parameters within 10 s")
results["params"] = params
print(json.dumps(results), flush=True)
