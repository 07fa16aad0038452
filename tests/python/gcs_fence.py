"""A geofence from the ground station, as a ground station sets it, uploads it and flies against
it, reported so that tests/gcs_fence.rs can compare ArduCopter SITL with `kestrel run`.

Usage: gcs_fence.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)

1. identify the vehicle, ask for every stream at 4 Hz, and read AUTOPILOT_VERSION's
   MISSION_FENCE capability bit;
2. PARAM_SET FENCE_ENABLE 1, FENCE_TYPE 7 (ceiling, circle, polygons), FENCE_ALT_MAX 40,
   FENCE_RADIUS 300, FENCE_ACTION 1 (RTL or land): the echoes;
3. two malformed fence uploads (a polygon of 2 vertices; vertices whose counts differ): each
   one's MISSION_ACK;
4. the fence: an inclusion square of 200 m about home and an exclusion circle of 15 m radius 50 m
   north; its MISSION_ACK and the count downloaded back;
5. GUIDED, armed, a 10 m take-off; then DO_REPOSITION targets outside the square, inside the
   circle, and above the ceiling: each COMMAND_ACK, and how far the vehicle moved;
6. a DO_REPOSITION to 90 m north, inside the square: its path crosses the circle. The mode the
   breach switches to, FENCE_STATUS while breached, and once the vehicle is out of the circle
   again (the breach cleared).

The last line's `results` holds `fence_capability`, `params` (name: echo), `malformed` (case:
ACK), `upload` ({ack, count}), `targets` (case: ACK), `moved_m`, `breach` ({mode, status,
count, type}) and `cleared` ({status, count, type, text}).
"""

import math

from gcs_common import arm_in_guided, distance_m, download, enum_name, Failed, main, mav, upload, VEHICLE

STREAM_HZ = 4
HOME = (6.79710, 79.90170)
TAKEOFF_M = 10.0
SQUARE_M = 100.0
CIRCLE_NORTH_M = 50.0
CIRCLE_RADIUS_M = 15.0
PARAMS = [("FENCE_ENABLE", 1), ("FENCE_TYPE", 7), ("FENCE_ALT_MAX", 40), ("FENCE_RADIUS", 300),
          ("FENCE_ACTION", 1)]
M_PER_DEG_LAT = 110_574.0  # near the equator: good to a metre over these distances


def offset(north_m, east_m):
    lat = HOME[0] + north_m / M_PER_DEG_LAT
    lon = HOME[1] + east_m / (M_PER_DEG_LAT * math.cos(math.radians(HOME[0])))
    return int(round(lat * 1e7)), int(round(lon * 1e7))


def fence_item(kind, param1, north_m, east_m):
    """A fence item `north_m`, `east_m` from home, as ground stations send fences (relative
    altitude frame, no altitude)."""
    x, y = offset(north_m, east_m)
    return dict(command=kind, frame=mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                params=[float(param1), 0.0, 0.0, 0.0], x=x, y=y, alt=0.0, autocontinue=1)


def square(count=4):
    s = SQUARE_M
    kind = mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
    return [fence_item(kind, count, n, e) for n, e in ((-s, -s), (s, -s), (s, s), (-s, s))]


def upload_fence(gcs, items, step):
    """The fence upload; the MISSION_ACK's result name."""
    return upload(gcs, items, step, mav.MAV_MISSION_TYPE_FENCE, timeout_s=5.0)


def reposition(gcs, north_m, east_m, alt_m, step):
    """DO_REPOSITION (COMMAND_INT, relative altitude) as QGroundControl's "Go to location"."""
    x, y = offset(north_m, east_m)
    gcs.log(f"-> COMMAND_INT DO_REPOSITION {north_m} m N {east_m} m E {alt_m} m")
    gcs.conn.mav.command_int_send(*VEHICLE, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                  mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 0, 0, math.nan, x, y, alt_m)
    ack = gcs.wait_type("COMMAND_ACK", 3.0, step, lambda m: m.command == mav.MAV_CMD_DO_REPOSITION)
    return enum_name("MAV_RESULT", ack.result)


def fence(gcs):
    statuses = []

    def watch(m):
        if m.get_type() == "FENCE_STATUS":
            s = (m.breach_status, m.breach_count, enum_name("FENCE_BREACH", m.breach_type))
            if not statuses or statuses[-1] != s:
                gcs.log(f"FENCE_STATUS status={s[0]} count={s[1]} type={s[2]}")
            statuses.append(s)

    gcs.watchers.append(watch)
    gcs.identify(timeout_s=20.0)
    gcs.log("-> REQUEST_DATA_STREAM ALL 4 Hz")
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, STREAM_HZ, 1)

    # 1. The capability.
    gcs.conn.mav.command_long_send(*VEHICLE, mav.MAV_CMD_REQUEST_MESSAGE, 0, 148, 0, 0, 0, 0, 0, 0)
    version = gcs.wait_type("AUTOPILOT_VERSION", 5.0, "autopilot version")
    gcs.results["fence_capability"] = bool(
        version.capabilities & mav.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE)

    # 2. The parameters.
    gcs.results["params"] = {
        name: gcs.set_param(name, float(value), f"set {name}").param_value for name, value in PARAMS}

    # 3. Malformed uploads.
    mixed = square()
    mixed[2]["params"][0] = 5.0
    gcs.results["malformed"] = {
        "two_vertices": upload_fence(gcs, square(2)[:2], "two vertices"),
        "counts_differ": upload_fence(gcs, mixed, "counts differ"),
    }

    # 4. The fence.
    circle = fence_item(mav.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, CIRCLE_RADIUS_M, CIRCLE_NORTH_M, 0.0)
    ack = upload_fence(gcs, square() + [circle], "fence upload")
    count = len(download(gcs, "fence count", mav.MAV_MISSION_TYPE_FENCE))
    gcs.results["upload"] = {"ack": ack, "count": count}
    if ack != "MAV_MISSION_ACCEPTED":
        raise Failed("fence upload", ack)

    # 5. Take-off, and targets beyond the fence.
    arm_in_guided(gcs)
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "takeoff")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 0.7, 30.0, "climb")
    before = gcs.position
    gcs.results["targets"] = {
        "outside_polygon": reposition(gcs, 150.0, 0.0, TAKEOFF_M, "outside the square"),
        "inside_exclusion": reposition(gcs, CIRCLE_NORTH_M, 0.0, TAKEOFF_M, "inside the circle"),
        "above_ceiling": reposition(gcs, 10.0, 0.0, 60.0, "above the ceiling"),
    }
    gcs.quiet(1.0)
    gcs.results["moved_m"] = round(distance_m(before, gcs.position), 1)

    # 6. A leg across the exclusion circle: the breach, its action, its end.
    gcs.results["targets"]["across_exclusion"] = reposition(gcs, 90.0, 0.0, TAKEOFF_M, "across")
    breached = gcs.pump(lambda m: m.get_type() == "FENCE_STATUS" and m.breach_status == 1, 60.0,
                        "breach")
    gcs.pump(lambda m: gcs.mode != "GUIDED", 10.0, "breach action")
    gcs.results["breach"] = {"mode": gcs.mode, "status": breached.breach_status,
                             "count": breached.breach_count,
                             "type": enum_name("FENCE_BREACH", breached.breach_type),
                             "north_m": round(distance_m(HOME, gcs.position), 1)}
    cleared = gcs.pump(lambda m: m.get_type() == "FENCE_STATUS" and m.breach_status == 0, 60.0,
                       "breach cleared")
    gcs.quiet(0.5)
    gcs.results["cleared"] = {"status": cleared.breach_status, "count": cleared.breach_count,
                              "type": enum_name("FENCE_BREACH", cleared.breach_type),
                              "mode": gcs.mode,
                              "text": any("Fence breach cleared" in t for t in gcs.statustexts)}

    # 7. FENCE_TOTAL: the count of stored items, as ArduCopter derives it (4 vertices, 1 circle, +2).
    gcs.results["fence_total"] = gcs.read_param("FENCE_TOTAL", "FENCE_TOTAL")

    # 8. RTL under a ceiling: down to 6 m in GUIDED, FENCE_ALT_MAX 14 (less FENCE_MARGIN 2: 12 m),
    # then RTL, whose RTL_ALT (15 m on both) the ceiling caps; the highest it flies on the way.
    gcs.set_mode_command("GUIDED", "guided after the breach")
    reposition(gcs, 30.0, 0.0, 6.0, "down to 6 m")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m <= 6.5, 40.0, "descend")
    gcs.set_param("FENCE_ALT_MAX", 14.0, "ceiling 14 m")
    gcs.set_mode_command("RTL", "rtl under the ceiling")
    peak = [0.0]

    def homewards(m):
        peak[0] = max(peak[0], gcs.rel_alt_m or 0.0)
        return m.get_type() == "GLOBAL_POSITION_INT" and distance_m(HOME, gcs.position) < 8.0

    gcs.pump(homewards, 60.0, "rtl home")
    gcs.results["rtl_capped"] = {"peak_m": round(peak[0], 1)}
    gcs.log(f"RTL under the ceiling: highest {peak[0]:.2f} m")

    # 9. RTL from above: hovering at 12 m, the ceiling lowered to 10 m breaches it; the RTL the
    # breach starts returns at the altitude it is at rather than descend to the ceiling.
    gcs.set_mode_command("GUIDED", "guided at home")
    gcs.set_param("FENCE_ALT_MAX", 10.0, "ceiling 10 m")
    above = gcs.pump(lambda m: m.get_type() == "FENCE_STATUS" and m.breach_status == 1, 10.0,
                     "ceiling breach")
    gcs.pump(lambda m: gcs.mode == "RTL", 10.0, "ceiling breach action")
    # The first 2 s of the vehicle's own time (its boot clock: ArduCopter runs 10x real time),
    # before RTL's loiter at home (ArduCopter's RTL_LOITER_TIME 5 s, Kestrel's 2 s once within
    # 1 m of home) ends in the descent.
    low, start = [gcs.rel_alt_m], gcs.boot_s

    def lowest(m):
        low[0] = min(low[0], gcs.rel_alt_m)
        return gcs.boot_s >= start + 2.0

    gcs.pump(lowest, 30.0, "rtl from above")
    gcs.results["rtl_from_above"] = {"mode": gcs.mode,
                                     "type": enum_name("FENCE_BREACH", above.breach_type),
                                     "kept_altitude": low[0] >= 11.0}
    gcs.log(f"RTL from above: lowest {low[0]:.2f} m in 2 s")

    # 10. MAV_CMD_DO_LAND_START: FAILED with no landing sequence; with a mission holding one,
    # ACCEPTED and the mission flown from it (ArduCopter calls the mode AUTO RTL, 27; Kestrel AUTO).
    no_sequence = gcs.command(mav.MAV_CMD_DO_LAND_START, [], "land start without a sequence",
                              expect=mav.MAV_RESULT_FAILED)
    # The first leg (60 m south) stays clear of the exclusion circle, which Kestrel checks at AUTO start.
    items = [waypoint(0.0, 0.0, 0.0), waypoint(-60.0, 0.0, 10.0),
             dict(frame=mav.MAV_FRAME_MISSION, command=mav.MAV_CMD_DO_LAND_START, autocontinue=1,
                  params=[0.0, 0.0, 0.0, 0.0], x=0, y=0, alt=0.0),
             waypoint(0.0, 20.0, 10.0), waypoint(0.0, 20.0, 0.0, mav.MAV_CMD_NAV_LAND)]
    if upload_mission(gcs, items) != "MAV_MISSION_ACCEPTED":
        raise Failed("mission upload", "refused")
    ack = gcs.command(mav.MAV_CMD_DO_LAND_START, [], "land start")
    # What the mission flies from now on (MISSION_CURRENT changes only): never its first leg.
    gcs.mission_currents.clear()
    gcs.pump(lambda m: gcs.mission_current is not None and gcs.mission_current >= 3, 10.0,
             "landing sequence")
    gcs.pump(lambda m: m.get_type() == "GLOBAL_POSITION_INT"
             and distance_m(offset_deg(0.0, 20.0), gcs.position) < 4.0, 40.0, "landing leg")
    gcs.results["land_start"] = {
        "no_sequence": enum_name("MAV_RESULT", no_sequence.result),
        "ack": enum_name("MAV_RESULT", ack.result),
        "first_leg_flown": 1 in gcs.mission_currents,
        "mode": gcs.mode,
        "text": any("Landing sequence start" in t for t in gcs.statustexts),
    }
    gcs.log(f"results: {gcs.results}")


def upload_mission(gcs, items):
    """MISSION_COUNT and every requested item of a mission; returns the MISSION_ACK's result."""
    gcs.conn.mav.mission_count_send(*VEHICLE, len(items), mav.MAV_MISSION_TYPE_MISSION)
    while True:
        m = gcs.pump(lambda m: gcs.from_vehicle(m) and m.get_type() in
                     ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK")
                     and m.mission_type == mav.MAV_MISSION_TYPE_MISSION, 5.0, "mission upload")
        if m.get_type() == "MISSION_ACK":
            return enum_name("MAV_MISSION_RESULT", m.type)
        it = items[m.seq]
        gcs.conn.mav.mission_item_int_send(
            *VEHICLE, m.seq, it["frame"], it["command"], 0, it["autocontinue"], *it["params"],
            it["x"], it["y"], it["alt"], mav.MAV_MISSION_TYPE_MISSION)


def offset_deg(north_m, east_m):
    x, y = offset(north_m, east_m)
    return x / 1e7, y / 1e7


def waypoint(north_m, east_m, alt_m, command=mav.MAV_CMD_NAV_WAYPOINT):
    x, y = offset(north_m, east_m)
    return dict(frame=mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command=command, autocontinue=1,
                params=[0.0, 0.0, 0.0, 0.0], x=x, y=y, alt=alt_m)


main(fence, deadline_s=220.0)
