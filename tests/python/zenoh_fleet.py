"""A fleet seen, and commanded, over Zenoh by a client that knows nothing of Kestrel's code:
the `eclipse-zenoh` Python package, a peer that connects to every vehicle, scouting off.

Usage: zenoh_fleet.py GCS_CONFIG VIEWER_CONFIG SECONDS VEHICLE=ENDPOINT... --command VEHICLE
(run by tests/zenoh_fleet.rs; the configs are config/zenoh/fleet-gcs.json5 and fleet-viewer.json5)

The ground station logs in as `gcs` (GCS_CONFIG: its Zenoh id and password) and subscribes to
`kestrel/*/nav_state`, `kestrel/*/vehicle_status` and `kestrel/*/command_result`, decoding each
payload as JSON by the schema named in its encoding. Once every VEHICLE has sent NavStates and
the commanded one reports itself armable with a position estimate, it tries to arm that vehicle
from where it must not be obeyed, watching its status all along:
  * an intruder with no credentials (the vehicle refuses the connection);
  * the `viewer` (VIEWER_CONFIG), which logs in and may watch but not command (Zenoh's access
    control drops its puts);
  * the ground station itself with no timestamp, and with a timestamp that names the viewer's
    Zenoh id (Zenoh lets both through; the bridge refuses a command from a source it does not list).
Then it commands as a ground station may, each command stamped with `session.new_timestamp()`:
a take-off while disarmed, stamped an hour in the future (the bridge clamps the time and the
commander refuses the take-off), an arm (accepted), and an arm with an id in the link's range
(the bridge refuses it: no answer). The last line is one JSON object: per vehicle its figures,
the answers to the commands, and what each refused attempt saw.
"""

import argparse
import json
import math
import threading
import time
from datetime import datetime, timedelta, timezone

import zenoh

# Command ids a Zenoh client may use (kestrel_bridge::catalogue::FIRST_BRIDGED_COMMAND_ID).
FIRST_ID = 1 << 31
EARTH_RADIUS_M = 6_378_137.0

args = argparse.ArgumentParser()
args.add_argument("gcs_config")
args.add_argument("viewer_config")
args.add_argument("seconds", type=float)
args.add_argument("vehicles", nargs="+", help="VEHICLE=ENDPOINT")
args.add_argument("--command", required=True)
args = args.parse_args()
endpoints = dict(v.split("=", 1) for v in args.vehicles)
args.vehicles = list(endpoints)

lock = threading.Lock()
vehicles = {}
results = {}
start = time.monotonic()


def log(text):
    print(f"{time.monotonic() - start:7.2f} {text}", flush=True)


def figures(vehicle):
    return vehicles.setdefault(vehicle, {
        "nav_states": 0, "statuses": 0, "encodings": [], "timestamped": 0,
        "attachments": 0, "position_ned_m": None, "origin": None, "armable": False,
        "armed_seen": False, "east_m_from_first": None, "positioned": False,
    })


def on_sample(sample):
    _, vehicle, topic = str(sample.key_expr).split("/")
    encoding = str(sample.encoding)
    msg = json.loads(sample.payload.to_bytes())
    with lock:
        f = figures(vehicle)
        if encoding not in f["encodings"]:
            f["encodings"].append(encoding)
        f["timestamped"] += sample.timestamp is not None
        f["attachments"] += sample.attachment is not None
        if topic == "nav_state":
            f["nav_states"] += 1
            f["position_ned_m"] = msg["position_ned_m"]
            f["origin"] = msg["origin"]
            valid = msg["valid"]
            f["positioned"] = bool(valid["horizontal_position"] and valid["vertical_position"] and msg["origin"])
        elif topic == "vehicle_status":
            f["statuses"] += 1
            f["armable"] = bool(msg.get("armable"))
            if msg["armed"] and not f["armed_seen"]:
                log(f"{vehicle} armed")
            f["armed_seen"] |= bool(msg["armed"])
        elif topic == "command_result":
            results[msg["id"]] = {"vehicle": vehicle, "refusal": msg["refusal"]}
            log(f"{vehicle} answered command {msg['id']}: {msg['refusal'] or 'accepted'}")


# Tries of a command that gets no answer, and how long each waits for one (s).
COMMAND_TRIES = 3
COMMAND_WAIT_S = 3.0


def wait_for(condition, what, limit_s):
    deadline = time.monotonic() + limit_s
    while time.monotonic() < deadline:
        with lock:
            if condition():
                return True
        time.sleep(0.05)
    log(f"gave up waiting for {what}")
    return False


def east_of(reference, other):
    """East distance (m) of `other`'s position from `reference`'s, through their origins."""
    (r, o) = (reference, other)
    if r["origin"] is None or o["origin"] is None:
        return None
    dlon = math.radians(o["origin"]["lon_deg"] - r["origin"]["lon_deg"])
    east = dlon * EARTH_RADIUS_M * math.cos(math.radians(r["origin"]["lat_deg"]))
    return east + o["position_ned_m"][1] - r["position_ned_m"][1]


def session_config(path, connect):
    """A client's Zenoh config: `path` (None: Zenoh's defaults, no credentials) connecting to `connect`."""
    config = zenoh.Config.from_file(path) if path else zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("connect/endpoints", json.dumps(connect))
    config.insert_json5("scouting/multicast/enabled", "false")
    return config


key = f"kestrel/{args.command}/vehicle_command"
encoding = zenoh.Encoding("application/json;kestrel.VehicleCommand")


def command_json(command_id, command):
    return json.dumps({"id": command_id, "time": 0, "command": command})


# Tries of a refused attempt, and how long the vehicle is watched after them (s).
ATTEMPT_TRIES = 3
ATTEMPT_WATCH_S = 2.0


def attempt(name, put):
    """Sends an arm ATTEMPT_TRIES times through `put(payload)`, then watches the vehicle."""
    command_id = FIRST_ID + 100 + len(attempts)
    for _ in range(ATTEMPT_TRIES):
        put(command_json(command_id, "arm"))
        time.sleep(0.3)
    time.sleep(ATTEMPT_WATCH_S)
    with lock:
        outcome = {
            "id": command_id,
            "answered": command_id in results,
            "armed": figures(args.command)["armed_seen"],
        }
    attempts[name] = outcome
    log(f"{name}: {outcome}")
    return outcome


attempts = {}
with zenoh.open(session_config(args.gcs_config, list(endpoints.values()))) as session:
    subscribers = [
        session.declare_subscriber(f"kestrel/*/{topic}", on_sample)
        for topic in ("nav_state", "vehicle_status", "command_result")
    ]
    log(f"ground station {session.zid()} connecting to {sorted(endpoints.values())}")
    all_seen = wait_for(
        lambda: all(vehicles.get(v, {}).get("nav_states", 0) >= 5 for v in args.vehicles),
        "NavStates from every vehicle", args.seconds)
    # Armable, and a position estimate: the commander's GUIDED needs one to arm in.
    ready = all_seen and wait_for(
        lambda: figures(args.command)["armable"] and figures(args.command)["positioned"],
        f"{args.command} armable with a position estimate", args.seconds)
    target = [endpoints[args.command]]
    viewer_id = None
    if ready:
        with zenoh.open(session_config(None, target)) as intruder:
            time.sleep(1.0)
            peers = len(intruder.info.peers_zid())
            attempt("intruder", lambda p: intruder.put(key, p, encoding=encoding,
                                                       timestamp=intruder.new_timestamp()))
            attempts["intruder"]["peers"] = peers
        with zenoh.open(session_config(args.viewer_config, target)) as viewer:
            seen = []
            watching = viewer.declare_subscriber(f"kestrel/{args.command}/nav_state", lambda s: seen.append(1))
            time.sleep(1.0)
            peers = len(viewer.info.peers_zid())
            viewer_id = viewer.new_timestamp().get_id()
            attempt("viewer", lambda p: viewer.put(key, p, encoding=encoding, timestamp=viewer.new_timestamp()))
            attempts["viewer"]["peers"] = peers
            attempts["viewer"]["nav_states_seen"] = len(seen)
            watching.undeclare()
        attempt("gcs_unstamped", lambda p: session.put(key, p, encoding=encoding))
        attempt("gcs_as_viewer", lambda p: session.put(
            key, p, encoding=encoding, timestamp=zenoh.Timestamp(datetime.now(timezone.utc), viewer_id)))
    hour_ahead = lambda: zenoh.Timestamp(datetime.now(timezone.utc) + timedelta(hours=1),
                                         session.new_timestamp().get_id())
    commands = [
        (FIRST_ID + 1, {"takeoff": {"altitude_m": 5.0}}, hour_ahead),
        (FIRST_ID + 2, "arm", session.new_timestamp),
        (12, "arm", session.new_timestamp),
    ]
    for (command_id, command, stamp) in commands if ready else []:
        # Zenoh drops a put that reaches no subscriber yet (the vehicle's declaration may still
        # be on its way), so an unanswered command is sent again with the same id, as a ground
        # station retries a COMMAND_LONG (MAVSDK: three tries); one in the link's own id range is
        # sent once, and must never be answered.
        tries = COMMAND_TRIES if command_id >= FIRST_ID else 1
        for attempt_number in range(1, tries + 1):
            session.put(key, command_json(command_id, command), encoding=encoding, timestamp=stamp())
            log(f"sent command {command_id} (try {attempt_number}): {json.dumps(command)}")
            if command_id < FIRST_ID:
                time.sleep(1.0)
            elif wait_for(lambda: command_id in results, f"the answer to {command_id}", COMMAND_WAIT_S):
                break
    wait_for(lambda: figures(args.command)["armed_seen"], f"{args.command} armed", 5.0 if ready else 0.0)
    with lock:
        first = vehicles.get(args.vehicles[0])
        for v in args.vehicles[1:]:
            if first and v in vehicles:
                vehicles[v]["east_m_from_first"] = east_of(first, vehicles[v])
        summary = {
            "vehicles": vehicles,
            "results": {str(k): v for k, v in results.items()},
            "attempts": attempts,
        }
    for s in subscribers:
        s.undeclare()
print(json.dumps(summary), flush=True)
