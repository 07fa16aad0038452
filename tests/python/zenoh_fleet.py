"""A fleet seen, and commanded, over Zenoh by a client that knows nothing of Kestrel's code:
the `eclipse-zenoh` Python package, a peer listening on ENDPOINT, scouting off.

Usage: zenoh_fleet.py ENDPOINT SECONDS VEHICLE... --command VEHICLE   (run by tests/zenoh_fleet.rs)

It subscribes to `kestrel/*/nav_state`, `kestrel/*/vehicle_status` and `kestrel/*/command_result`
and decodes each payload as JSON by the schema named in its encoding. Once every VEHICLE has
sent NavStates and the commanded one reports itself armable with a position estimate, it publishes VehicleCommands to
`kestrel/<command vehicle>/vehicle_command`, as a script would: a take-off while disarmed (the
commander refuses it), an arm (accepted), and an arm with an id in the link's range (the bridge
refuses it: no answer). The last line is one JSON object: per vehicle its figures, and the
answers to the commands.
"""

import argparse
import json
import math
import threading
import time

import zenoh

# Command ids a Zenoh client may use (kestrel_bridge::catalogue::FIRST_BRIDGED_COMMAND_ID).
FIRST_ID = 1 << 31
EARTH_RADIUS_M = 6_378_137.0

args = argparse.ArgumentParser()
args.add_argument("endpoint")
args.add_argument("seconds", type=float)
args.add_argument("vehicles", nargs="+")
args.add_argument("--command", required=True)
args = args.parse_args()

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


config = zenoh.Config()
config.insert_json5("mode", '"peer"')
config.insert_json5("listen/endpoints", json.dumps([args.endpoint]))
config.insert_json5("scouting/multicast/enabled", "false")
with zenoh.open(config) as session:
    subscribers = [
        session.declare_subscriber(f"kestrel/*/{topic}", on_sample)
        for topic in ("nav_state", "vehicle_status", "command_result")
    ]
    log(f"listening on {args.endpoint}")
    all_seen = wait_for(
        lambda: all(vehicles.get(v, {}).get("nav_states", 0) >= 5 for v in args.vehicles),
        "NavStates from every vehicle", args.seconds)
    # Armable, and a position estimate: the commander's GUIDED needs one to arm in.
    ready = all_seen and wait_for(
        lambda: figures(args.command)["armable"] and figures(args.command)["positioned"],
        f"{args.command} armable with a position estimate", args.seconds)
    commands = [
        (FIRST_ID + 1, {"takeoff": {"altitude_m": 5.0}}),
        (FIRST_ID + 2, "arm"),
        (12, "arm"),
    ]
    key = f"kestrel/{args.command}/vehicle_command"
    encoding = zenoh.Encoding("application/json;kestrel.VehicleCommand")
    for (command_id, command) in commands if ready else []:
        # Zenoh drops a put that reaches no subscriber yet (the vehicle's declaration may still
        # be on its way), so an unanswered command is sent again with the same id, as a ground
        # station retries a COMMAND_LONG (MAVSDK: three tries); one in the link's own id range is
        # sent once, and must never be answered.
        tries = COMMAND_TRIES if command_id >= FIRST_ID else 1
        for attempt in range(1, tries + 1):
            # No timestamp: the bridge takes a client's command as given on arrival.
            session.put(key, json.dumps({"id": command_id, "time": 0, "command": command}), encoding=encoding)
            log(f"sent command {command_id} (try {attempt}): {json.dumps(command)}")
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
        summary = {"vehicles": vehicles, "results": {str(k): v for k, v in results.items()}}
    for s in subscribers:
        s.undeclare()
print(json.dumps(summary), flush=True)
