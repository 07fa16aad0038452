"""A ground station on the companion computer's port (actors/link/tests/companion_arducopter.rs):
ArduCopter SITL is on the companion's flight-controller endpoint, this client on one of its
ground-station endpoints, and everything it sees and sends goes through Kestrel's companion link.

1. both heartbeats: ArduCopter (system 1, component 1, a quadrotor) and the companion (system 1,
   component 196, MAV_TYPE_ONBOARD_CONTROLLER, MAV_AUTOPILOT_INVALID);
2. GUIDED, armed, a take-off to TAKEOFF_M (default 3 m), all through the companion;
3. ArduCopter's own proximity report (PRX1_TYPE = 2): the DISTANCE_SENSOR it sends per 45° face
   from the OBSTACLE_DISTANCE the companion sent it, kept per orientation with the companion's
   OBSTACLE_DISTANCE frames seen here.

The last line's `results`: `companion_heartbeat` (type, autopilot), `max_rel_alt_m`,
`proximity_cm` (orientation -> the last current_distance ArduCopter reported), `obstacle_distance`
(count, frame, increment_f, and the first 24 distances of the last one seen), `duplicates`
(frames from system 1 seen twice in a row: same component, sequence number and type).
"""

import os

from gcs_common import (accepted, arm_in_guided, Failed, main, mav, VEHICLE)

TAKEOFF_M = float(os.environ.get("TAKEOFF_M", "3"))
COMPANION = (1, 196)


def flight(gcs):
    proximity = {}
    obstacle = {"count": 0}
    companion = {}
    last_seq = {}
    duplicates = [0]

    def watch_all(m):
        src = (m.get_srcSystem(), m.get_srcComponent())
        if src[0] == 1 and m.get_type() != "BAD_DATA":
            # A source numbers its frames one by one: the same number and type twice in a row
            # from one source is one frame delivered twice.
            this = (m.get_seq(), m.get_type())
            if last_seq.get(src) == this:
                duplicates[0] += 1
            last_seq[src] = this
        if src == COMPANION:
            if m.get_type() == "HEARTBEAT" and not companion:
                companion["type"] = m.type
                companion["autopilot"] = m.autopilot
                gcs.log(f"companion HEARTBEAT type={m.type} autopilot={m.autopilot}")
            elif m.get_type() == "OBSTACLE_DISTANCE":
                obstacle["count"] += 1
                obstacle["frame"] = m.frame
                obstacle["increment_f"] = m.increment_f
                obstacle["distances"] = list(m.distances[:24]) + [m.distances[71]]
        elif src == VEHICLE and m.get_type() == "DISTANCE_SENSOR":
            if m.orientation not in proximity:
                gcs.log(f"ArduCopter DISTANCE_SENSOR orientation={m.orientation} {m.current_distance} cm")
            proximity[m.orientation] = m.current_distance

    # Every message, the companion's included (observe() keeps only the vehicle's).
    original = gcs.observe

    def observe(m):
        watch_all(m)
        original(m)

    gcs.observe = observe
    gcs.identify(timeout_s=30.0)
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 4, 1)
    gcs.pump(lambda m: bool(companion), 10.0, "companion heartbeat")
    arm_in_guided(gcs)
    while not accepted(gcs, mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "take-off"):
        if not gcs.armed or (gcs.rel_alt_m or 0.0) > 1.0:
            break
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 0.5, 30.0, "take-off")
    # ArduCopter's proximity filters each face (PRX_FILT): wait until the front and right faces
    # read the companion's distances.
    gcs.pump(lambda m: abs(proximity.get(0, 0) - 300) <= 5 and abs(proximity.get(2, 0) - 750) <= 5,
             15.0, "ArduCopter's proximity")
    gcs.results["companion_heartbeat"] = companion
    gcs.results["max_rel_alt_m"] = round(gcs.max_rel_alt_m, 2)
    gcs.results["proximity_cm"] = {str(k): v for k, v in sorted(proximity.items())}
    gcs.results["obstacle_distance"] = obstacle
    gcs.results["duplicates"] = duplicates[0]


main(flight, deadline_s=float(os.environ.get("DEADLINE_S", "60")))
