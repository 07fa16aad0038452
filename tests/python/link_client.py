"""A ground station made of pymavlink, flying the Kestrel link through its paces.

Listens on an ephemeral UDP port on 127.0.0.1 (as QGroundControl listens on 14550), prints
`PORT <n>` so the test can point the vehicle's UDP client at it, then: identifies the vehicle,
fetches and sets parameters, uploads a mission and downloads it back, arms, switches to AUTO,
checks an unsupported command, switches the fence off, moves home, sets the current
mission item, and stops its heartbeats to see the link-loss report. Prints one
JSON line of results and exits 0 when every step passed.
"""

import json
import sys
import time

from pymavlink import mavutil

mav = mavutil.mavlink
results = {}
conn = mavutil.mavlink_connection("udpin:127.0.0.1:0", source_system=255, source_component=190)
print("PORT", conn.port.getsockname()[1], flush=True)
last_gcs_heartbeat = 0.0
heartbeats_on = True


def fail(step, detail):
    print(json.dumps({"failed": step, "detail": str(detail), "results": results}), flush=True)
    sys.exit(1)


def pump(types, cond, timeout, step):
    """Receives messages of `types` until `cond(msg)` is true, sending GCS heartbeats at 1 Hz."""
    global last_gcs_heartbeat
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if heartbeats_on and time.monotonic() - last_gcs_heartbeat > 1.0:
            conn.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            last_gcs_heartbeat = time.monotonic()
        msg = conn.recv_match(type=types, blocking=True, timeout=0.1)
        if msg is not None and cond(msg):
            return msg
    fail(step, "timed out")


# 1. Identify the vehicle.
hb = pump("HEARTBEAT", lambda m: m.get_srcSystem() == 1 and m.get_srcComponent() == 1, 10, "heartbeat")
conn.target_system, conn.target_component = 1, 1
results["vehicle"] = {
    "type": mav.enums["MAV_TYPE"][hb.type].name,
    "autopilot": mav.enums["MAV_AUTOPILOT"][hb.autopilot].name,
    "mode": conn.flightmode,
}
if hb.type != mav.MAV_TYPE_QUADROTOR:
    fail("heartbeat", hb)

# 2. Fetch every parameter, then set one in range and one out of range.
t0 = time.monotonic()
conn.mav.param_request_list_send(1, 1)
params = {}


def got_all(m):
    params[m.param_id] = m.param_value
    return len(params) == m.param_count


pump("PARAM_VALUE", got_all, 5, "param list")
results["params"] = {"count": len(params), "fetch_s": round(time.monotonic() - t0, 4)}
conn.mav.param_set_send(1, 1, b"RTL_ALT_M", 50.0, mav.MAV_PARAM_TYPE_REAL32)
pump("PARAM_VALUE", lambda m: m.param_id == "RTL_ALT_M" and m.param_value == 50.0, 3, "param set")
conn.mav.param_set_send(1, 1, b"RTL_ALT_M", 500.0, mav.MAV_PARAM_TYPE_REAL32)
pump("PARAM_VALUE", lambda m: m.param_id == "RTL_ALT_M" and m.param_value == 50.0, 3, "param refused")
results["params"]["set"] = "RTL_ALT_M=50 accepted, 500 refused"

# 3. Upload a mission (item 0 is home, ArduPilot convention) and download it back.
home = (6.79710, 79.90170)
items = [
    (mav.MAV_CMD_NAV_WAYPOINT, home[0], home[1], 0.0),
    (mav.MAV_CMD_NAV_TAKEOFF, home[0], home[1], 20.0),
    (mav.MAV_CMD_NAV_WAYPOINT, home[0] + 0.0005, home[1], 25.0),
    (mav.MAV_CMD_NAV_WAYPOINT, home[0] + 0.0005, home[1] + 0.0005, 25.0),
    (mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0.0, 0.0, 0.0),
]
t0 = time.monotonic()
conn.mav.mission_count_send(1, 1, len(items), mav.MAV_MISSION_TYPE_MISSION)
while True:
    m = pump(["MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"], lambda m: True, 3, "mission upload")
    if m.get_type() == "MISSION_ACK":
        if m.type != mav.MAV_MISSION_ACCEPTED:
            fail("mission upload", m)
        break
    cmd, lat, lon, alt = items[m.seq]
    conn.mav.mission_item_int_send(
        1, 1, m.seq, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, cmd, 0, 1,
        0, 0, 0, 0, int(round(lat * 1e7)), int(round(lon * 1e7)), alt, mav.MAV_MISSION_TYPE_MISSION)
results["mission"] = {"uploaded": len(items), "upload_s": round(time.monotonic() - t0, 4)}
conn.mav.mission_request_list_send(1, 1, mav.MAV_MISSION_TYPE_MISSION)
count = pump("MISSION_COUNT", lambda m: True, 3, "mission count").count
back = []
for seq in range(count):
    conn.mav.mission_request_int_send(1, 1, seq, mav.MAV_MISSION_TYPE_MISSION)
    it = pump("MISSION_ITEM_INT", lambda m, s=seq: m.seq == s, 3, "mission download")
    back.append((it.command, it.x / 1e7, it.y / 1e7, it.z))
conn.mav.mission_ack_send(1, 1, mav.MAV_MISSION_ACCEPTED, mav.MAV_MISSION_TYPE_MISSION)
same = len(back) == len(items) and all(
    b[0] == i[0] and abs(b[1] - round(i[1] * 1e7) / 1e7) < 1e-9 and abs(b[2] - round(i[2] * 1e7) / 1e7) < 1e-9
    and b[3] == i[3] for b, i in zip(back, items))
if not same:
    fail("mission download", back)
results["mission"]["downloaded_identical"] = True

# 4. Arm, switch to AUTO, and see both in the heartbeat.
conn.mav.command_long_send(1, 1, mav.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
ack = pump("COMMAND_ACK", lambda m: m.command == mav.MAV_CMD_COMPONENT_ARM_DISARM, 3, "arm")
if ack.result != mav.MAV_RESULT_ACCEPTED:
    fail("arm", ack)
conn.set_mode("AUTO")
pump("HEARTBEAT", lambda m: m.get_srcSystem() == 1 and conn.flightmode == "AUTO"
     and m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED, 3, "auto")
results["flight"] = {"armed": True, "mode": conn.flightmode}

# 5. An unsupported command is refused at once.
t0 = time.monotonic()
conn.mav.command_long_send(1, 1, mav.MAV_CMD_DO_PARACHUTE, 0, 1, 0, 0, 0, 0, 0, 0)
ack = pump("COMMAND_ACK", lambda m: m.command == mav.MAV_CMD_DO_PARACHUTE, 3, "unsupported")
if ack.result != mav.MAV_RESULT_UNSUPPORTED:
    fail("unsupported", ack)
results["unsupported_ack_s"] = round(time.monotonic() - t0, 4)

# 6. Fence off (announced), home moved (HOME_POSITION follows), current item set (MISSION_CURRENT).
conn.mav.command_long_send(1, 1, mav.MAV_CMD_DO_FENCE_ENABLE, 0, 0, 0, 0, 0, 0, 0, 0)
fence = {}


def fence_answered(m):
    """The ACK and the STATUSTEXT come in one batch, the text first: both are kept."""
    if m.get_type() == "COMMAND_ACK" and m.command == mav.MAV_CMD_DO_FENCE_ENABLE:
        fence["ack"] = m.result
    elif m.get_type() == "STATUSTEXT" and "Geofence disabled" in m.text:
        fence["text"] = m.text
    return "ack" in fence and "text" in fence


pump(["COMMAND_ACK", "STATUSTEXT"], fence_answered, 3, "fence")
if fence["ack"] != mav.MAV_RESULT_ACCEPTED:
    fail("fence", fence)
conn.mav.command_int_send(1, 1, mav.MAV_FRAME_GLOBAL, mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 0, 0,
                          int(round((home[0] + 0.0001) * 1e7)), int(round(home[1] * 1e7)), 25.0)
ack = pump("COMMAND_ACK", lambda m: m.command == mav.MAV_CMD_DO_SET_HOME, 3, "set home")
if ack.result != mav.MAV_RESULT_ACCEPTED:
    fail("set home", ack)
moved = pump("HOME_POSITION", lambda m: m.altitude == 25000, 3, "home position")
conn.mav.command_long_send(1, 1, mav.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 0, 95.0, 0, 0)
ack = pump("COMMAND_ACK", lambda m: m.command == mav.MAV_CMD_DO_SET_HOME, 3, "bad home")
if ack.result != mav.MAV_RESULT_DENIED:
    fail("bad home", ack)
conn.mav.command_long_send(1, 1, mav.MAV_CMD_DO_SET_MISSION_CURRENT, 0, 3, 0, 0, 0, 0, 0, 0)
ack = pump("COMMAND_ACK", lambda m: m.command == mav.MAV_CMD_DO_SET_MISSION_CURRENT, 3, "mission current")
if ack.result != mav.MAV_RESULT_ACCEPTED:
    fail("mission current", ack)
pump("MISSION_CURRENT", lambda m: m.seq == 3, 3, "mission current seq")
conn.mav.command_long_send(1, 1, mav.MAV_CMD_DO_SET_MISSION_CURRENT, 0, len(items), 0, 0, 0, 0, 0, 0)
ack = pump("COMMAND_ACK", lambda m: m.command == mav.MAV_CMD_DO_SET_MISSION_CURRENT, 3, "past the end")
if ack.result != mav.MAV_RESULT_FAILED:
    fail("past the end", ack)
conn.mav.mission_set_current_send(1, 1, 2)
pump("MISSION_CURRENT", lambda m: m.seq == 2, 3, "mission set current")
results["gcs_commands"] = {"fence": "off", "home_lat": moved.latitude / 1e7, "mission_current": 2}

# 7. Fall silent: the vehicle reports the lost ground station.
heartbeats_on = False
t0 = time.monotonic()
pump("STATUSTEXT", lambda m: "GCS heartbeat lost" in m.text, 6, "link loss")
results["link_loss_reported_after_s"] = round(time.monotonic() - t0, 2)
results["mavlink_version_in_use"] = 2 if conn.WIRE_PROTOCOL_VERSION == "2.0" else 1
print(json.dumps({"ok": True, "results": results}), flush=True)
