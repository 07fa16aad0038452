"""Flies `kestrel run` (config/sim.toml, unchanged) with MAVSDK as its users run it: PyPI `mavsdk`,
whose wheel carries the C++ MAVSDK core, on its default connection `udpin://0.0.0.0:14540`.

Usage: mavsdk_flight.py SCENARIO [PLAN.plan]   (run by tests/gcs_mavsdk.rs)

    takeoff_land   arm, take off to 8 m, land: in air, 8 m, on the ground, disarmed
    mission        import a QGroundControl .plan with MAVSDK's importer, upload it, download it
                   identical, arm, start, follow the progress to the end, land near home
    offboard       Offboard velocity: a 10 m square in NED, back within 2 m of the start; then
                   `set_velocity_body` 2 m/s forward turning 30 °/s: over one turn of the
                   heading, a circle of radius v/ω = 3.8 m at 2 m/s
    goto_hold_rtl  goto_location 20 m north, hold there, do_orbit an 8 m circle at 2 m/s (the
                   positions reported lie on it and turn at v / r), RTL: landed near home,
                   disarmed
    failure_gps    the Failure plugin: GPS off DENIED while SYS_FAILURE_EN is 0; set it to 1
                   (Param plugin), take off to 8 m, inject GPS off: global position lost, LAND
                   (the fault matrix's "GPS lost" row: estimator_unhealthy → land), landed,
                   disarmed
    log_files      take off to 5 m, land; LogFiles: the entries, the newest downloaded equal to
                   the vehicle's file ($KESTREL_STATE_DIR/sim/logs, byte for byte) and read by the
                   `mcap` reader (tests/python/read_mcap.py) from vehicle_status armed to disarmed
    geofence       Geofence: upload an inclusion square of 200 m about home and an exclusion
                   circle of 15 m radius 50 m north; take off to 10 m; goto_location outside the
                   square refused, the vehicle stays; goto_location 90 m north (across the
                   circle): the breach's action, RETURN_TO_LAUNCH, from near the circle's edge

Every check reads what MAVSDK reports (telemetry, action and mission results), never the
vehicle's log. One line per step goes to stdout (`wall_s step: detail`); the exit code is 0
when every check held, 1 with `FAILED step: why` otherwise.
"""

import asyncio
import gc
import json
import math
import os
import sys
import time

from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.failure import FailureAsync
from mavsdk.asyncio.plugins.follow_me import FollowMeAsync
from mavsdk.asyncio.plugins.geofence import GeofenceAsync
from mavsdk.asyncio.plugins.log_files import LogFilesAsync
from mavsdk.asyncio.plugins.mavlink_direct import MavlinkDirectAsync
from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
from mavsdk.asyncio.plugins.offboard import OffboardAsync
from mavsdk.asyncio.plugins.param import ParamAsync
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
from mavsdk.plugins.action import ActionError, OrbitYawBehavior
from mavsdk.plugins.failure import FailureError, FailureResult, FailureType, FailureUnit
from mavsdk.plugins.follow_me import FollowMeError, TargetLocation
from mavsdk.plugins.mavlink_direct import MavlinkMessage
from mavsdk.plugins.geofence import Circle, FenceType, GeofenceData, Point, Polygon
from mavsdk.plugins.offboard import VelocityBodyYawspeed, VelocityNedYaw
from mavsdk.plugins.telemetry import FlightMode, LandedState

CONNECTION = "udpin://0.0.0.0:14540"
START = time.monotonic()
# Simulated seconds per wall second of the vehicle (`kestrel run --speedup`): the offboard
# square's legs are timed in vehicle seconds, so each side is 10 m at any speed-up.
SPEEDUP = float(os.environ.get("KESTREL_SPEEDUP", "1"))


class Failed(Exception):
    pass


def log(step, detail=""):
    print(f"{time.monotonic() - START:7.2f} {step}: {detail}", flush=True)


def distance_m(a, b):
    """Horizontal distance between two telemetry positions (flat earth, m)."""
    north = (b.latitude_deg - a.latitude_deg) * 110_574.0
    east = (b.longitude_deg - a.longitude_deg) * 111_320.0 * math.cos(math.radians(a.latitude_deg))
    return math.hypot(north, east)


async def until(step, probe, timeout_s, period_s=0.1):
    """Polls `probe()` (an awaitable factory) until it returns something truthy."""
    end = time.monotonic() + timeout_s
    last = None
    while time.monotonic() < end:
        last = await probe()
        if last:
            log(step, "ok")
            return last
        await asyncio.sleep(period_s)
    raise Failed(f"{step}: not within {timeout_s} s (last {last!r})")


class Vehicle:
    def __init__(self, system):
        self.action = ActionAsync(system)
        self.telemetry = TelemetryAsync(system)
        self.mission = MissionRawAsync(system)
        self.offboard = OffboardAsync(system)
        self.failure = FailureAsync(system)
        self.param = ParamAsync(system)
        self.log_files = LogFilesAsync(system)
        self.geofence = GeofenceAsync(system)
        self.follow_me = FollowMeAsync(system)
        self.mavlink_direct = MavlinkDirectAsync(system)

    async def ready(self):
        health = await until("health: armable, global position, home",
                             self._armable, 60.0, 0.5)
        log("health", f"{health}")
        return await self.telemetry.position()

    async def _armable(self):
        h = await self.telemetry.health()
        ok = h.is_armable and h.is_global_position_ok and h.is_home_position_ok
        return h if ok else None

    async def arm(self):
        await self.action.arm()
        await until("armed (telemetry)", self.telemetry.armed, 5.0)

    async def relative_altitude(self):
        return (await self.telemetry.position()).relative_altitude_m

    async def landed_and_disarmed(self, timeout_s):
        async def down():
            state = await self.telemetry.landed_state()
            return state == LandedState.ON_GROUND and not await self.telemetry.armed()
        await until("on the ground and disarmed", down, timeout_s, 0.2)


async def takeoff_land(v):
    await v.ready()
    await v.action.set_takeoff_altitude(8.0)
    await v.arm()
    await v.action.takeoff()
    log("takeoff", "accepted")
    await until("in air", v.telemetry.in_air, 20.0)

    async def at_8():
        alt = await v.relative_altitude()
        return alt if abs(alt - 8.0) < 0.5 else None
    alt = await until("at 8 m", at_8, 40.0)
    log("altitude", f"{alt:.2f} m")
    await asyncio.sleep(2.0)
    hover = await v.relative_altitude()
    log("hover", f"{hover:.2f} m after 2 s")
    if abs(hover - 8.0) > 0.5:
        raise Failed(f"hover: {hover:.2f} m, not 8 m")
    await v.action.land()
    log("land", "accepted")
    await v.landed_and_disarmed(60.0)


def item_key(i):
    return (i.seq, i.frame, i.command, i.current, i.autocontinue, round(i.param1, 4), round(i.param2, 4),
            round(i.param3, 4), i.x, i.y, round(i.z, 3), i.mission_type)


async def mission(v, plan):
    home = await v.ready()
    imported = await v.mission.import_qgroundcontrol_mission(plan)
    items = imported.mission_items
    log("import", f"{len(items)} items from {plan}")
    await v.mission.upload_mission(items)
    log("upload", "accepted")
    downloaded = await v.mission.download_mission()
    if [item_key(i) for i in downloaded] != [item_key(i) for i in items]:
        raise Failed(f"download: differs\n up {[item_key(i) for i in items]}\n down {[item_key(i) for i in downloaded]}")
    log("download", f"{len(downloaded)} items, identical")
    await v.arm()
    await v.mission.start_mission()
    log("start_mission", "accepted")
    await until("in air", v.telemetry.in_air, 20.0)
    seen = []

    async def finished():
        p = await v.mission.mission_progress()
        if not seen or (p.current, p.total) != seen[-1]:
            seen.append((p.current, p.total))
            log("progress", f"{p.current}/{p.total}")
        return await v.mission.is_mission_finished()
    await until("mission finished", finished, 150.0, 0.2)
    currents = [c for c, _ in seen]
    if currents != sorted(currents) or max(currents) < len(items) - 1:
        raise Failed(f"progress: {seen} does not advance to {len(items) - 1}")
    await v.landed_and_disarmed(90.0)
    end = await v.telemetry.position()
    off = distance_m(home, end)
    log("landed", f"{off:.2f} m from home")
    if off > 3.0:
        raise Failed(f"landed {off:.2f} m from home")


async def offboard(v):
    await v.ready()
    await v.action.set_takeoff_altitude(8.0)
    await v.arm()
    await v.action.takeoff()

    async def up():
        return await v.relative_altitude() > 7.5
    await until("at take-off height", up, 40.0)
    await asyncio.sleep(2.0)
    start = (await v.telemetry.position_velocity_ned()).position
    log("start", f"N {start.north_m:.2f} E {start.east_m:.2f} D {start.down_m:.2f}")
    await v.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, 0.0, 0.0))
    await v.offboard.start()
    await until("flight mode OFFBOARD", lambda: _mode_is(v, FlightMode.OFFBOARD), 5.0)
    corners = []
    for north, east in [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]:
        await v.offboard.set_velocity_ned(VelocityNedYaw(north * 2.0, east * 2.0, 0.0, 0.0))
        await asyncio.sleep(5.0 / SPEEDUP)
        p = (await v.telemetry.position_velocity_ned()).position
        corners.append((p.north_m - start.north_m, p.east_m - start.east_m))
        log("corner", f"N {corners[-1][0]:.2f} E {corners[-1][1]:.2f}")
    await v.offboard.set_velocity_ned(VelocityNedYaw(0.0, 0.0, 0.0, 0.0))
    await asyncio.sleep(3.0 / SPEEDUP)
    end = (await v.telemetry.position_velocity_ned()).position
    off = math.hypot(end.north_m - start.north_m, end.east_m - start.east_m)
    log("square", f"ended {off:.2f} m from its start")
    await body_circle(v)
    await v.offboard.stop()
    # The square's corners as flown: each side about 10 m (2 m/s for 5 vehicle seconds).
    expected = [(10, 0), (10, 10), (0, 10), (0, 0)]
    for (n, e), (en, ee) in zip(corners, expected):
        if math.hypot(n - en, e - ee) > 3.0:
            raise Failed(f"square: corner N {n:.2f} E {e:.2f}, expected near N {en} E {ee}")
    if off > 2.0:
        raise Failed(f"square: ended {off:.2f} m from its start")
    await v.action.land()
    await v.landed_and_disarmed(60.0)


async def _mode_is(v, mode):
    return await v.telemetry.flight_mode() == mode


async def goto_hold_rtl(v):
    home = await v.ready()
    await v.action.set_takeoff_altitude(10.0)
    await v.arm()
    await v.action.takeoff()

    async def up():
        return await v.relative_altitude() > 9.5
    await until("at take-off height", up, 40.0)
    target_lat = home.latitude_deg + 20.0 / 110_574.0
    await v.action.goto_location(target_lat, home.longitude_deg, home.absolute_altitude_m + 12.0, 0.0)
    log("goto_location", "accepted")

    async def there():
        p = await v.telemetry.position()
        north = (p.latitude_deg - home.latitude_deg) * 110_574.0
        return p if abs(north - 20.0) < 1.0 and abs(p.relative_altitude_m - 12.0) < 1.0 else None
    p = await until("at the goto target", there, 60.0)
    await v.action.hold()
    await until("flight mode HOLD", lambda: _mode_is(v, FlightMode.HOLD), 5.0)
    await asyncio.sleep(5.0)
    held = await v.telemetry.position()
    drift = distance_m(p, held)
    log("hold", f"drifted {drift:.2f} m in 5 s")
    if drift > 1.5:
        raise Failed(f"hold: drifted {drift:.2f} m")
    await orbit(v, held)
    await v.action.return_to_launch()
    await until("flight mode RETURN_TO_LAUNCH", lambda: _mode_is(v, FlightMode.RETURN_TO_LAUNCH), 5.0)
    await v.landed_and_disarmed(120.0)
    end = await v.telemetry.position()
    off = distance_m(home, end)
    log("landed", f"{off:.2f} m from home")
    if off > 3.0:
        raise Failed(f"RTL landed {off:.2f} m from home")


def fit_circle(points):
    """Kasa's algebraic least-squares circle through (north, east) points (m): centre, radius."""
    n = len(points)
    mx, my = sum(p[0] for p in points) / n, sum(p[1] for p in points) / n
    u = [(p[0] - mx, p[1] - my) for p in points]
    suu, svv = sum(a * a for a, _ in u), sum(b * b for _, b in u)
    suv = sum(a * b for a, b in u)
    r1 = 0.5 * (sum(a ** 3 for a, _ in u) + sum(a * b * b for a, b in u))
    r2 = 0.5 * (sum(b ** 3 for _, b in u) + sum(b * a * a for a, b in u))
    det = suu * svv - suv * suv
    uc, vc = (r1 * svv - r2 * suv) / det, (r2 * suu - r1 * suv) / det
    return (uc + mx, vc + my), math.sqrt(uc * uc + vc * vc + (suu + svv) / n)


async def orbit(v, here):
    """`action.do_orbit`: ORBIT_R_M round a centre ORBIT_R_M east of `here`, at ORBIT_V_M_S,
    facing the centre; the positions telemetry reports over ORBIT_S of vehicle time must lie on
    that circle (least-squares fit: radius within 1 m, RMS off it under 0.5 m) and turn
    clockwise at about v / r."""
    ORBIT_R_M, ORBIT_V_M_S, ORBIT_S = 8.0, 2.0, 16.0
    centre_lat = here.latitude_deg
    centre_lon = here.longitude_deg + ORBIT_R_M / (111_320.0 * math.cos(math.radians(here.latitude_deg)))
    await v.action.do_orbit(ORBIT_R_M, ORBIT_V_M_S, OrbitYawBehavior.HOLD_FRONT_TO_CIRCLE_CENTER,
                            centre_lat, centre_lon, here.absolute_altitude_m)
    log("do_orbit", f"accepted; flight mode {await v.telemetry.flight_mode()}")
    await asyncio.sleep(2.0 / SPEEDUP)
    samples = []
    end = time.monotonic() + ORBIT_S / SPEEDUP
    while time.monotonic() < end:
        p = await v.telemetry.position()
        north = (p.latitude_deg - centre_lat) * 110_574.0
        east = (p.longitude_deg - centre_lon) * 111_320.0 * math.cos(math.radians(centre_lat))
        samples.append((time.monotonic(), north, east))
        await asyncio.sleep(0.1)
    (cn, ce), radius = fit_circle([(n, e) for _, n, e in samples])
    rms = math.sqrt(sum((math.hypot(n - cn, e - ce) - radius) ** 2 for _, n, e in samples) / len(samples))
    angles = [math.atan2(e, n) for _, n, e in samples]
    turned = sum((b - a + math.pi) % (2 * math.pi) - math.pi for a, b in zip(angles, angles[1:]))
    rate = turned / ((samples[-1][0] - samples[0][0]) * SPEEDUP)
    log("orbit", f"radius {radius:.2f} m, RMS {rms:.3f} m, centre {math.hypot(cn, ce):.2f} m off, "
                 f"rate {rate:.3f} rad/s over {len(samples)} positions")
    if abs(radius - ORBIT_R_M) > 1.0 or rms > 0.5 or math.hypot(cn, ce) > 1.0:
        raise Failed(f"orbit: radius {radius:.2f} m, RMS {rms:.3f} m round a centre {math.hypot(cn, ce):.2f} m off")
    if abs(rate - ORBIT_V_M_S / ORBIT_R_M) > 0.05:
        raise Failed(f"orbit: {rate:.3f} rad/s, wanted {ORBIT_V_M_S / ORBIT_R_M:.3f}")


async def failure_gps(v):
    await v.ready()
    try:
        await v.failure.inject(FailureUnit.SENSOR_GPS, FailureType.OFF, 0)
        raise Failed("inject with SYS_FAILURE_EN 0: accepted")
    except FailureError as e:
        if e.result != FailureResult.DENIED:
            raise Failed(f"inject with SYS_FAILURE_EN 0: {e.result.name}, not DENIED")
        log("disabled", f"{e.result.name}")
    await v.param.set_param_int("SYS_FAILURE_EN", 1)
    enabled = await v.param.get_param_int("SYS_FAILURE_EN")
    if enabled != 1:
        raise Failed(f"SYS_FAILURE_EN reads {enabled} after setting 1")
    log("enabled", f"SYS_FAILURE_EN = {enabled}")
    await v.action.set_takeoff_altitude(8.0)
    await v.arm()
    await v.action.takeoff()

    async def up():
        return abs(await v.relative_altitude() - 8.0) < 0.5
    await until("at 8 m", up, 40.0)
    await asyncio.sleep(2.0 / SPEEDUP)
    await v.failure.inject(FailureUnit.SENSOR_GPS, FailureType.OFF, 0)
    injected = time.monotonic()
    log("inject", "GPS off: SUCCESS")

    async def position_lost():
        return not (await v.telemetry.health()).is_global_position_ok
    await until("global position lost", position_lost, 15.0, 0.1)
    await until("flight mode LAND", lambda: _mode_is(v, FlightMode.LAND), 20.0)
    log("land", f"{(time.monotonic() - injected) * SPEEDUP:.1f} vehicle s after the injection")
    await v.landed_and_disarmed(90.0)
    log("landed", "on the ground, disarmed")


async def log_files(v):
    await v.ready()
    await v.action.set_takeoff_altitude(5.0)
    await v.arm()
    await v.action.takeoff()
    await until("in air", v.telemetry.in_air, 20.0)
    await asyncio.sleep(1.0)
    await v.action.land()
    await v.landed_and_disarmed(60.0)
    started = time.monotonic()
    entries = await v.log_files.get_entries()
    log("entries", ", ".join(f"{e.id}: {e.size_bytes} B {e.date}" for e in entries))
    if not entries:
        raise Failed("entries: none")
    newest = entries[-1]
    log_dir = os.path.join(os.environ["KESTREL_STATE_DIR"], "sim", "logs")
    names = sorted(n for n in os.listdir(log_dir) if n.endswith(".mcap"))
    on_disk = open(os.path.join(log_dir, names[-1]), "rb").read()
    if (len(entries), newest.size_bytes) != (len(names), len(on_disk)):
        raise Failed(f"entries: {len(entries)} entries, newest {newest.size_bytes} B; on disk {names}, "
                     f"newest {len(on_disk)} B")
    path = os.path.join(os.getcwd(), "downloaded.mcap")
    async for result, progress in v.log_files.download_log_file(newest, path):
        pass
    data = open(path, "rb").read()
    log("download", f"{len(data)} B in {time.monotonic() - started:.1f} s")
    if data != on_disk:
        raise Failed(f"download: {len(data)} B differ from the vehicle's {names[-1]} ({len(on_disk)} B)")
    sys.path.insert(0, os.path.dirname(__file__))
    from read_mcap import topic_span
    span = topic_span(path, "vehicle_status")
    log("mcap", f"{len(span['topics'])} topics, vehicle_status armed {span['first']['armed']} .. "
                f"{span['last']['armed']}")
    if (span["first"]["armed"], span["last"]["armed"]) != (True, False):
        raise Failed("mcap: the log is not the flight from arming to disarming")


async def geofence(v):
    home = await v.ready()
    m_lat = 1.0 / 110_574.0
    m_lon = 1.0 / (110_574.0 * math.cos(math.radians(home.latitude_deg)))

    def point(north_m, east_m):
        return Point(home.latitude_deg + north_m * m_lat, home.longitude_deg + east_m * m_lon)
    square = Polygon([point(n, e) for n, e in ((-100, -100), (100, -100), (100, 100), (-100, 100))],
                     FenceType.INCLUSION)
    circle = Circle(point(50.0, 0.0), 15.0, FenceType.EXCLUSION)
    await v.geofence.upload_geofence(GeofenceData([square], [circle]))
    log("upload_geofence", "accepted")
    await v.action.set_takeoff_altitude(10.0)
    await v.arm()
    await v.action.takeoff()

    async def up():
        return await v.relative_altitude() > 9.5
    await until("at take-off height", up, 40.0)
    before = await v.telemetry.position()
    alt = home.absolute_altitude_m + 10.0
    outside = point(150.0, 0.0)
    try:
        await v.action.goto_location(outside.latitude_deg, outside.longitude_deg, alt, 0.0)
        raise Failed("goto_location outside the fence: accepted")
    except ActionError as e:
        log("goto_location outside", f"refused: {e.result.name}")
    await asyncio.sleep(2.0)
    moved = distance_m(before, await v.telemetry.position())
    if moved > 2.0:
        raise Failed(f"moved {moved:.1f} m after a refused goto")
    across = point(90.0, 0.0)
    await v.action.goto_location(across.latitude_deg, across.longitude_deg, alt, 0.0)
    log("goto_location across the circle", "accepted")
    await until("flight mode RETURN_TO_LAUNCH", lambda: _mode_is(v, FlightMode.RETURN_TO_LAUNCH), 60.0)
    north = (await v.telemetry.position()).latitude_deg - home.latitude_deg
    log("breach", f"RETURN_TO_LAUNCH at {north / m_lat:.1f} m north")
    if not 25.0 < north / m_lat < 45.0:
        raise Failed(f"breach action at {north / m_lat:.1f} m north, the circle's edge is at 35 m")


async def body_circle(v, speed_m_s=2.0, rate_deg_s=30.0):
    """`set_velocity_body` forward at `speed_m_s` turning at `rate_deg_s`: the body velocity turns
    with the nose, so the vehicle flies a circle of radius v/ω. Once up to speed, the positions
    MAVSDK reports over one full turn of its heading are fitted with a circle (least squares,
    Kåsa): its radius must be v/ω, every point near it, and the ground speed v. Nothing here is
    timed by the wall clock, so a slow host (lockstep below its speed-up) flies the same shape."""
    omega = math.radians(rate_deg_s)
    radius = speed_m_s / omega
    await v.offboard.set_velocity_body(VelocityBodyYawspeed(speed_m_s, 0.0, 0.0, rate_deg_s))

    async def up_to_speed():
        vel = (await v.telemetry.position_velocity_ned()).velocity
        return math.hypot(vel.north_m_s, vel.east_m_s) > 0.9 * speed_m_s
    await until("spin-up to 2 m/s", up_to_speed, 30.0, 0.05)
    points, speeds = [], []
    turned, last = 0.0, (await v.telemetry.heading()).heading_deg
    end = time.monotonic() + 90.0
    while turned < 360.0:
        if time.monotonic() > end:
            raise Failed(f"circle: turned only {turned:.0f} deg in 90 s")
        pv = await v.telemetry.position_velocity_ned()
        points.append((pv.position.north_m, pv.position.east_m))
        speeds.append(math.hypot(pv.velocity.north_m_s, pv.velocity.east_m_s))
        h = (await v.telemetry.heading()).heading_deg
        turned += (h - last + 180.0) % 360.0 - 180.0
        last = h
        await asyncio.sleep(0.05)
    await v.offboard.set_velocity_body(VelocityBodyYawspeed(0.0, 0.0, 0.0, 0.0))
    # Kåsa's fit: x² + y² = 2 a x + 2 b y + c, least squares in (a, b, c); r² = c + a² + b².
    n = len(points)
    sx = sum(x for x, _ in points); sy = sum(y for _, y in points)
    sxx = sum(x * x for x, _ in points); syy = sum(y * y for _, y in points)
    sxy = sum(x * y for x, y in points)
    sz = [x * x + y * y for x, y in points]
    rhs = [sum(z * x for z, (x, _) in zip(sz, points)), sum(z * y for z, (_, y) in zip(sz, points)), sum(sz)]
    m = [[2 * sxx, 2 * sxy, sx], [2 * sxy, 2 * syy, sy], [2 * sx, 2 * sy, n]]

    def det(a):
        return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
    d = det(m)
    sol = []
    for col in range(3):
        mc = [row[:] for row in m]
        for r in range(3):
            mc[r][col] = rhs[r]
        sol.append(det(mc) / d)
    cn, ce, c = sol
    fitted = math.sqrt(c + cn * cn + ce * ce)
    worst = max(abs(math.hypot(x - cn, y - ce) - fitted) for x, y in points)
    speed = sum(speeds) / len(speeds)
    log("circle", f"{n} samples over one turn: radius {fitted:.2f} m (v/ω = {radius:.2f} m), farthest "
                  f"point {worst:.2f} m off it, ground speed {speed:.2f} m/s (asked {speed_m_s})")
    if abs(fitted - radius) > 0.2 * radius or worst > 0.25 * radius:
        raise Failed(f"circle: radius {fitted:.2f} m, a point {worst:.2f} m off; expected {radius:.2f} m")
    if abs(speed - speed_m_s) > 0.15 * speed_m_s:
        raise Failed(f"circle: ground speed {speed:.2f} m/s, asked {speed_m_s}")



async def follow_me(v, speed_m_s=3.0, walk_s=15.0, ahead_m=5.0):
    home = await v.ready()
    # Kestrel declares its parameters REAL32 (ArduCopter's FOLL_ENABLE is an INT8).
    await v.param.set_param_float("FOLL_ENABLE", 1.0)
    await v.action.set_takeoff_altitude(10.0)
    await v.arm()
    await v.action.takeoff()

    async def up():
        return await v.relative_altitude() > 9.5
    await until("at take-off height", up, 40.0)
    await asyncio.sleep(2.0)
    start = await v.telemetry.position()
    north_m = lambda p: (p.latitude_deg - home.latitude_deg) * 110_574.0
    east_m = lambda p: (p.longitude_deg - home.longitude_deg) * 111_320.0 * math.cos(math.radians(home.latitude_deg))
    n0, e0 = north_m(start), east_m(start)

    def target_at(t_s):
        walked = speed_m_s * min(max(t_s, 0.0), walk_s)
        lat = home.latitude_deg + (n0 + ahead_m + walked) / 110_574.0
        lon = start.longitude_deg
        v_n = speed_m_s if 0.0 <= t_s < walk_s else 0.0
        return lat, lon, home.absolute_altitude_m, v_n

    lat, lon, alt, _ = target_at(0.0)
    # MAVSDK's own answer on an ArduPilot vehicle, recorded as it is.
    try:
        await v.follow_me.set_target_location(TargetLocation(lat, lon, alt, 0.0, 0.0, 0.0))
        plugin = "SUCCESS"
    except FollowMeError as e:
        plugin = e.result.name
    log("set_target_location before start", plugin)

    async def send(t_s):
        lat, lon, alt, v_n = target_at(t_s)
        fields = {
            "timestamp": int(t_s * 1000), "est_capabilities": 1,
            "lat": int(round(lat * 1e7)), "lon": int(round(lon * 1e7)), "alt": alt,
            "vel": [v_n, 0.0, 0.0], "acc": [0.0, 0.0, 0.0], "attitude_q": [1.0, 0.0, 0.0, 0.0],
            "rates": [0.0, 0.0, 0.0], "position_cov": [0.0, 0.0, 0.0], "custom_state": 0,
        }
        await v.mavlink_direct.send_message(MavlinkMessage("FOLLOW_TARGET", 0, 0, 0, 0, json.dumps(fields)))

    await send(0.0)
    await v.follow_me.start()
    await until("flight mode FOLLOW_ME", lambda: _mode_is(v, FlightMode.FOLLOW_ME), 5.0)
    try:
        await v.follow_me.set_target_location(TargetLocation(lat, lon, alt, 0.0, 0.0, 0.0))
        plugin = "SUCCESS"
    except FollowMeError as e:
        plugin = e.result.name
    log("set_target_location in FOLLOW", plugin)
    if plugin != "NOT_ACTIVE":
        raise Failed(f"follow_me: set_target_location answered {plugin}: MAVSDK now sends on ArduPilot, "
                     "drop the MavlinkDirect stand-in")
    t0 = time.monotonic()
    errors = []
    while True:
        t = (time.monotonic() - t0) * SPEEDUP
        if t > walk_s + 8.0:
            break
        await send(t)
        p = await v.telemetry.position()
        tl, _, _, _ = target_at(t)
        # Where the vehicle should be: its place at the start, moved with the target.
        behind = (tl - home.latitude_deg) * 110_574.0 - ahead_m - north_m(p)
        side = east_m(p) - e0
        if t > 5.0:
            errors.append((t, behind, side, p.relative_altitude_m))
        await asyncio.sleep(0.2 / SPEEDUP)
    walking = [e for e in errors if e[0] < walk_s]
    stopped = [e for e in errors if e[0] > walk_s + 5.0]
    lag = sum(e[1] for e in walking) / len(walking)
    worst_side = max(abs(e[2]) for e in errors)
    worst_alt = max(abs(e[3] - 10.0) for e in errors)
    final = sum(abs(e[1]) for e in stopped) / len(stopped)
    end = await v.telemetry.position()
    log("follow", f"walking: {lag:.2f} m behind its place on average (position-only reports), "
                  f"{worst_side:.2f} m off the line at worst, height within {worst_alt:.2f} m of 10 m; "
                  f"stopped: {final:.2f} m from its place; flew {north_m(end) - n0:.1f} m north")
    if not (north_m(end) - n0 > 0.8 * speed_m_s * walk_s and final < 1.5 and worst_side < 1.5 and worst_alt < 1.5):
        raise Failed("follow: the vehicle did not keep its place relative to the target")
    await v.follow_me.stop()
    await v.action.land()
    await v.landed_and_disarmed(60.0)


SCENARIOS = {"takeoff_land": takeoff_land, "mission": mission, "offboard": offboard,
             "goto_hold_rtl": goto_hold_rtl, "failure_gps": failure_gps, "log_files": log_files,
             "geofence": geofence, "follow_me": follow_me}


async def run(name, args):
    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as mavsdk:
        await mavsdk.add_any_connection(CONNECTION)
        log("connect", CONNECTION)
        system = await mavsdk.first_autopilot(timeout_s=30.0)
        if system is None:
            raise Failed("connect: no autopilot within 30 s")
        log("autopilot", f"{await system.autopilot_type()} system {await system.get_system_id()}")
        vehicle = Vehicle(system)
        try:
            await SCENARIOS[name](vehicle, *args)
        finally:
            # Every plugin must be gone before the Mavsdk instance (its C++ core aborts the
            # process otherwise, exit 134). A plugin caught in a reference cycle (an error's
            # traceback holds the executor frame that called it) lives until a collection, so
            # collect here, on this thread, while the instance is still alive.
            del vehicle, system
            gc.collect()


def main():
    name = sys.argv[1]
    # No automatic collection: one run by whichever thread allocates (an executor or MAVSDK's
    # callback thread) can finalise a plugin while the main thread destroys the Mavsdk
    # instance; `run` collects once, at a safe point. Acyclic garbage is still freed at once.
    gc.disable()
    try:
        asyncio.run(run(name, sys.argv[2:]))
    except Failed as e:
        print(f"FAILED {e}", flush=True)
        sys.exit(1)
    except Exception as e:  # a MAVSDK error (ActionError, MissionRawError...) is a failed check
        print(f"FAILED {type(e).__name__}: {e}", flush=True)
        sys.exit(1)
    log("done", name)


if __name__ == "__main__":
    main()
