"""Replays of signed frames on `kestrel run`, and unsigned RADIO_STATUS on a signed link.

Usage: gcs_signing_replay.py KEY_HEX before|after CAPTURE_FILE REPLAY_PORT
(run twice by tests/gcs_pymavlink.rs, with a restart of the vehicle between; see gcs_common.py for the
transcript). The vehicle signs with KEY on two endpoints: a `udp_out` to this client and a
`udp_in` on REPLAY_PORT.

before: a signed REQUEST_MESSAGE is answered; the same bytes, captured, sent from another socket
        to the other endpoint get no answer at all (the peer is not even admitted); an unsigned
        RADIO_STATUS with 10 % buffer free cuts the telemetry rate; the captured frame is saved.
after:  the frame captured before the restart gets no answer; a fresh signed one does.
"""

import os
import socket
import sys
import time

os.environ["MAVLINK20"] = "1"  # signing is MAVLink 2; pymavlink must not start in MAVLink 1

from gcs_common import VEHICLE, Failed, main, mav  # noqa: E402

KEY = bytes.fromhex(sys.argv[1])
PHASE = sys.argv[2]
CAPTURE = sys.argv[3]
REPLAY_PORT = int(sys.argv[4])
AUTOPILOT_VERSION = 148


def request_version(gcs):
    """A signed REQUEST_MESSAGE(AUTOPILOT_VERSION), sent; returns its bytes as they went out."""
    msg = gcs.conn.mav.command_long_encode(
        *VEHICLE, mav.MAV_CMD_REQUEST_MESSAGE, 0, AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0)
    gcs.conn.mav.send(msg)
    return bytes(msg.get_msgbuf())


def is_ack(m):
    return m.get_type() == "COMMAND_ACK" and m.command == mav.MAV_CMD_REQUEST_MESSAGE


def no_ack(gcs, label, seconds=1.5):
    try:
        ack = gcs.pump(lambda m: is_ack(m) and gcs.from_vehicle(m), seconds, "no ack")
        raise Failed(label, f"answered: {ack}")
    except Failed as e:
        if e.step != "no ack":
            raise
    gcs.log(f"no COMMAND_ACK within {seconds} s ({label})")


def replay_elsewhere(gcs, raw):
    """Sends `raw` from a new socket to the vehicle's other endpoint: nothing may come back.
    The ground station keeps reading meanwhile, or its socket's buffer would fill and drop what
    the vehicle says next."""
    attacker = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    attacker.bind(("127.0.0.1", 0))
    attacker.setblocking(False)
    attacker.sendto(raw, ("127.0.0.1", REPLAY_PORT))
    end = time.monotonic() + 1.5
    while time.monotonic() < end:
        gcs.quiet(0.05)
        try:
            data, _ = attacker.recvfrom(65536)
            raise Failed("replay on the other endpoint", f"the vehicle answered ({len(data)} bytes)")
        except BlockingIOError:
            pass
    attacker.close()
    gcs.log(f"replay to the udp_in endpoint on {REPLAY_PORT}: nothing came back in 1.5 s")


def telemetry_rate(gcs, seconds):
    """Messages per second from the vehicle over `seconds` of wall time."""
    count = [0]

    def watch(m):
        count[0] += 1

    gcs.watchers.append(watch)
    gcs.quiet(seconds)
    gcs.watchers.remove(watch)
    return count[0] / seconds


def unsigned_radio_status(gcs, txbuf):
    """RADIO_STATUS as a SiK radio inserts it (system 51, component 68), unsigned, sent to where
    the vehicle's frames come from."""
    radio = mav.MAVLink(None, srcSystem=51, srcComponent=68)
    msg = radio.radio_status_encode(200, 190, txbuf, 0, 0, 0, 0)
    for vehicle in gcs.conn.clients:  # the addresses this udpin socket has heard from
        gcs.conn.port.sendto(msg.pack(radio), vehicle)


def before(gcs):
    gcs.identify()
    gcs.conn.setup_signing(KEY, sign_outgoing=True)
    gcs.wait_type("HEARTBEAT", 3.0, "signed heartbeat", lambda m: m.get_signed())
    raw = request_version(gcs)
    gcs.pump(lambda m: is_ack(m) and gcs.from_vehicle(m), 3.0, "signed request answered")
    gcs.log(f"signed REQUEST_MESSAGE answered; captured its {len(raw)} bytes")
    replay_elsewhere(gcs, raw)

    full = telemetry_rate(gcs, 2.0)
    unsigned_radio_status(gcs, 10)
    gcs.quiet(0.3)
    thinned = telemetry_rate(gcs, 2.0)
    gcs.log(f"telemetry {full:.1f}/s, then {thinned:.1f}/s after an unsigned RADIO_STATUS (10 % free)")
    if not thinned < 0.6 * full:
        raise Failed("radio status", f"telemetry not thinned: {full:.1f}/s then {thinned:.1f}/s")
    unsigned_radio_status(gcs, 100)

    with open(CAPTURE, "w") as f:
        f.write(raw.hex())
    gcs.results["before"] = {"replay_other_endpoint": "refused",
                             "telemetry_per_s": [round(full, 1), round(thinned, 1)]}


def after(gcs):
    with open(CAPTURE) as f:
        raw = bytes.fromhex(f.read())
    gcs.identify()
    gcs.conn.setup_signing(KEY, sign_outgoing=True)
    gcs.wait_type("HEARTBEAT", 3.0, "signed heartbeat", lambda m: m.get_signed())
    gcs.conn.write(raw)
    gcs.log("-> the REQUEST_MESSAGE captured before the restart, as it was")
    no_ack(gcs, "captured before the restart")
    replay_elsewhere(gcs, raw)
    request_version(gcs)
    gcs.pump(lambda m: is_ack(m) and gcs.from_vehicle(m), 3.0, "fresh signed request answered")
    gcs.log("a fresh signed REQUEST_MESSAGE is answered")
    gcs.results["after"] = {"captured_before_restart": "refused", "fresh": "answered"}


main(before if PHASE == "before" else after)
