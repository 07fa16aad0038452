"""Drives MAVProxy (mavproxy.py from the test venv) against `kestrel run`, as an operator types.

Usage: mavproxy_session.py   (run by tests/gcs_pymavlink.rs; `MAVPROXY_SCENARIO=calibrate` by
tests/gcs_calibration.rs: the sensor calibrations as an operator types them). `MavProxy` and
`run` are what tests/python/mavproxy_plans.py drives its own scenario with.

MAVProxy listens on an ephemeral UDP port on 127.0.0.1 (`--master udpin:...`, as it listens on
14550 by default); `PORT <n>` is printed first so the test points the vehicle's `udp_out` there.
Commands go to MAVProxy's standard input one at a time, each only after MAVProxy printed what
the previous one should make it print, so nothing here reads MAVLink itself: every check is
on MAVProxy's own console output. Transcript lines:

    <wall s since start>  mavproxy| <what MAVProxy printed>
    <wall s since start>  -> <command typed>

The last line is one JSON object: `{"ok": true, ...}` and exit 0, or `{"failed": STEP, ...}`
and exit 1.
"""

import json
import os
import queue
import re
import socket
import subprocess
import sys
import tempfile
import threading
import time

# MAVProxy's periodic noise, left out of the transcript.
NOISE = ("Unloading module", "Time has wrapped")


class Failed(Exception):
    def __init__(self, step, detail):
        super().__init__(f"{step}: {detail}")
        self.step = step
        self.detail = detail


def free_udp_port():
    """A port nothing on 127.0.0.1 uses right now, for MAVProxy to listen on."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class MavProxy:
    """One mavproxy.py process with its console lines collected by a reader thread."""

    def __init__(self, port, state_dir, deadline_s):
        self.t0 = time.monotonic()
        self.deadline = self.t0 + deadline_s
        # Where MAVProxy keeps its state and logs, and where a scenario writes the files it loads.
        self.state_dir = state_dir
        self.lines = queue.Queue()
        self.seen = []
        mavproxy = os.path.join(os.path.dirname(sys.executable), "mavproxy.py")
        self.proc = subprocess.Popen(
            [sys.executable, mavproxy, f"--master=udpin:127.0.0.1:{port}",
             "--state-basedir", state_dir, "--logfile", os.path.join(state_dir, "mav.tlog"),
             # The vehicle runs faster than the wall clock (`--speedup`): 10 Hz heartbeats keep
             # it well inside its 5 s (vehicle time) ground-station timeout.
             "--cmd", "set heartbeat 10"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, bufsize=1, cwd=state_dir)
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            # The prompt ("GUIDED> ") is printed without a newline before whatever comes next.
            line = re.sub(r"^(?:[A-Z_]+> )+", "", line.rstrip("\n"))
            self.lines.put(line)
        self.lines.put(None)

    def log(self, event):
        print(f"{time.monotonic() - self.t0:6.2f}s  {event}", flush=True)

    def type(self, command):
        self.log(f"-> {command}")
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()

    def expect(self, pattern, timeout_s, step):
        """Waits until MAVProxy prints a line matching `pattern`; returns the match."""
        end = min(time.monotonic() + timeout_s, self.deadline)
        regex = re.compile(pattern)
        while time.monotonic() < end:
            try:
                line = self.lines.get(timeout=max(0.0, min(0.1, end - time.monotonic())))
            except queue.Empty:
                continue
            if line is None:
                raise Failed(step, f"MAVProxy exited with {self.proc.wait()} waiting for /{pattern}/")
            if not line.strip() or line.startswith(NOISE):
                continue
            self.log(f"mavproxy| {line}")
            self.seen.append(line)
            m = regex.search(line)
            if m:
                return m
        raise Failed(step, f"MAVProxy did not print /{pattern}/ within {timeout_s} s")

    def close(self):
        """End of input: MAVProxy stops (it exits 1 whatever happened, so the code is ignored)."""
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=10)
        except (subprocess.TimeoutExpired, BrokenPipeError):
            self.proc.kill()
            self.proc.wait()


def session(mp, results):
    mp.expect(r"^Detected vehicle 1:1 on link 0", 15.0, "detect")
    mp.expect(r"^online system 1", 5.0, "online")
    mode = mp.expect(r"^Mode (\w+)", 5.0, "mode shown").group(1)
    results["vehicle"] = {"system": 1, "mode": mode}

    # MAVProxy fetches every parameter by itself once it sees the vehicle: it asks for the
    # parameter file (`@PARAM/param.pck`) over MAVFTP, as it does from ArduPilot.
    count = int(mp.expect(r"^Received (\d+) parameters", 20.0, "parameter download").group(1))
    mp.type("param show RTL_ALT_M")
    before = float(mp.expect(r"^RTL_ALT_M\s+(\S+)", 5.0, "param show").group(1))
    mp.type("param set RTL_ALT_M 21")
    # `param fetch` reads the value back from the vehicle (PARAM_REQUEST_READ) and prints
    # `NAME = VALUE`.
    time.sleep(0.5)
    mp.type("param fetch RTL_ALT_M")
    after = float(mp.expect(r"^RTL_ALT_M = (\S+)", 5.0, "param read back").group(1))
    if after != 21.0:
        raise Failed("param set", f"the vehicle reads back RTL_ALT_M = {after} after setting 21")
    results["params"] = {"count": count, "RTL_ALT_M": [before, after]}

    # With no radio the vehicle boots in GUIDED; MAVProxy prints a mode only when it changes.
    if mode != "GUIDED":
        raise Failed("mode shown", f"booted in {mode}, not GUIDED")
    mp.type("mode LOITER")
    mp.expect(r"^Got COMMAND_ACK: DO_SET_MODE: ACCEPTED", 5.0, "mode LOITER acked")
    mp.expect(r"^Mode LOITER", 5.0, "mode LOITER shown")
    mp.type("mode GUIDED")
    mp.expect(r"^Got COMMAND_ACK: DO_SET_MODE: ACCEPTED", 5.0, "mode GUIDED acked")
    mp.expect(r"^Mode GUIDED", 5.0, "mode GUIDED shown")
    mp.type("arm throttle")
    mp.expect(r"^Got COMMAND_ACK: COMPONENT_ARM_DISARM: ACCEPTED", 5.0, "arm acked")
    mp.expect(r"^ARMED", 5.0, "armed shown")
    mp.type("takeoff 5")
    mp.expect(r"^Got COMMAND_ACK: NAV_TAKEOFF: ACCEPTED", 5.0, "takeoff acked")
    climbed = wait_altitude(mp, 4.5, 20.0, "take-off climb")
    # Return home and land, watched through what MAVProxy shows.
    mp.type("mode RTL")
    mp.expect(r"^Got COMMAND_ACK: DO_SET_MODE: ACCEPTED", 5.0, "mode RTL acked")
    mp.expect(r"^Mode RTL", 5.0, "mode RTL shown")
    mp.expect(r"^DISARMED", 40.0, "landed and disarmed")
    results["flight"] = {"modes": ["LOITER", "GUIDED", "TAKEOFF", "RTL"], "climbed_m": climbed, "disarmed": True}


CALIBRATION_PARAMS = [f"COMPASS_{k}_{a}" for k in ("OFS", "DIA", "ODI") for a in "XYZ"] \
    + [f"INS_{k}_{a}" for k in ("ACCOFFS", "ACCSCAL") for a in "XYZ"] + ["AHRS_TRIM_X", "AHRS_TRIM_Y"]


def calibration(mp, results):
    """MAVProxy's `accelcal` (Enter at each "Place vehicle ..."), `ahrstrim` (level) and
    `magcal start` (autosave), then the parameters and arming, all read off its console."""
    mp.expect(r"^Detected vehicle 1:1 on link 0", 15.0, "detect")
    mp.expect(r"^Received (\d+) parameters", 20.0, "parameter download")
    mp.type("arm throttle")
    results["prearm_refusal"] = mp.expect(r"PreArm: .*", 5.0, "arm refused").group(0)

    mp.type("accelcal")
    positions = []
    while len(positions) < 6:
        m = mp.expect(r"Place vehicle (.+) and press any key|Calibration FAILED.*", 20.0, "accelcal position")
        if m.group(0).startswith("Calibration FAILED"):
            raise Failed("accelcal", m.group(0))
        positions.append(m.group(1))
        # The operator sets the vehicle down as asked (the simulator does) and presses Enter.
        time.sleep(0.3)
        mp.type("")
    mp.expect(r"^(?:AP: )?Calibration successful", 20.0, "accelcal done")
    results["accel_positions"] = positions

    mp.type("ahrstrim")
    mp.expect(r"level calibration successful", 10.0, "level")

    mp.type("magcal start")
    report = mp.expect(r"^Calibration of compass 0 (\w+): fitness (\S+)", 60.0, "magcal report")
    if report.group(1) != "SUCCESS":
        raise Failed("magcal", report.group(0))
    results["mag_fitness_mgauss"] = float(report.group(2))
    mp.expect(r"Compass calibration successful and saved", 10.0, "magcal saved")

    params = {}
    for name in CALIBRATION_PARAMS:
        mp.type(f"param fetch {name}")
        params[name] = float(mp.expect(rf"^{name} = (\S+)", 5.0, f"param {name}").group(1))
    results["params"] = params
    if any(line.startswith("ARMED") for line in mp.seen):
        raise Failed("arm refused", "the vehicle armed before it was calibrated")
    # The estimator aligns again on the new calibration first: the operator retries until the
    # vehicle accepts, as one would after ArduPilot's "PreArm: ..." texts.
    refusals = []
    end = time.monotonic() + 20.0
    while True:
        mp.type("arm throttle")
        ack = mp.expect(r"^Got COMMAND_ACK: COMPONENT_ARM_DISARM: (\w+)", 5.0, "arm after calibration")
        if ack.group(1) == "ACCEPTED":
            break
        refusals.append(mp.expect(r"^(?:AP: )?(.*(?:refused|PreArm).*)", 5.0, "arm refusal").group(1))
        if time.monotonic() > end:
            raise Failed("arm after calibration", refusals[-3:])
        time.sleep(1.0)
    results["arm_refusals_after"] = refusals
    mp.expect(r"^ARMED", 5.0, "armed shown")
    mp.type("disarm")
    mp.expect(r"^DISARMED", 5.0, "disarmed shown")
    results["armed_after"] = True


def wait_altitude(mp, alt_m, timeout_s, step):
    """Polls `status GLOBAL_POSITION_INT` until relative_alt reaches `alt_m`; returns it (m)."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        mp.type("status GLOBAL_POSITION_INT")
        rel = int(mp.expect(r"GLOBAL_POSITION_INT \{.*relative_alt : (-?\d+)", 5.0, step).group(1))
        if rel / 1000.0 >= alt_m:
            return rel / 1000.0
        time.sleep(0.5)
    raise Failed(step, f"below {alt_m} m after {timeout_s} s")


def run(scenario, deadline_s):
    """Runs `scenario(mp, results)` against a fresh MAVProxy listening on a free port (printed
    first) and ends the process with its outcome as the last JSON line; the whole session must
    end within `deadline_s` of wall time."""
    port = free_udp_port()
    print("PORT", port, flush=True)
    results = {}
    with tempfile.TemporaryDirectory(prefix="kestrel-mavproxy-") as state_dir:
        mp = MavProxy(port, state_dir, deadline_s)
        try:
            scenario(mp, results)
        except Failed as e:
            mp.log(f"FAILED {e.step}: {e.detail}")
            mp.close()
            print(json.dumps({"failed": e.step, "detail": str(e.detail), "results": results}), flush=True)
            sys.exit(1)
        mp.close()
    results["printed"] = len(mp.seen)
    print(json.dumps({"ok": True, "results": results}), flush=True)


if __name__ == "__main__":
    if os.environ.get("MAVPROXY_SCENARIO") == "calibrate":
        run(calibration, 90.0)
    else:
        run(session, 50.0)
