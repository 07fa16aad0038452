"""Logs and files on the vehicle, as a ground station fetches them: a short flight, then the log
list and download (LOG_* messages) and MAVLink FTP (pymavlink's mavftp). Written once, run
against `kestrel run` and ArduCopter SITL (tests/gcs_log_download.rs), which compares the reports.

Usage: gcs_logs.py   (prints `PORT <n>` first; see gcs_common.py for the transcript)
Environment: LOG_DIR, the vehicle's log directory, when the test can read it (Kestrel): the
downloaded log is compared with the file there byte for byte and opened with the `mcap` reader.
DOWNLOAD_LIMIT (bytes, default all): download at most this much of the newest log.

1. identify, ask for telemetry, GUIDED and arm (each retried until taken), take off to 5 m;
2. armed: LOG_REQUEST_LIST, expecting no LOG_ENTRY (and recording what was said);
3. LAND, wait until disarmed;
4. LOG_REQUEST_LIST: every LOG_ENTRY; the newest log downloaded with LOG_REQUEST_DATA (gaps
   asked for again), LOG_REQUEST_END; a request past its end;
5. PARAM_REQUEST_LIST; FTP: list `/` and `/logs`, fetch `@PARAM/param.pck` (decoded with
   pymavlink's own decoder), CRC of the newest log, and one write (CreateFile) refused or not.

The last line's `results` hold `armed_list` (LOG_ENTRY count and STATUSTEXTs while armed),
`entries` (each LOG_ENTRY's id, num_logs, last_log_num, size, time_utc > 0), `download`
(bytes, chunk sizes seen, the zero-length answer past the end), `params` (count by
PARAM_REQUEST_LIST), `ftp` (listings, param.pck's count and whether its values equal the list's,
CRC, the write's answer), and, with LOG_DIR, `on_disk` (equal bytes, mcap topics).
"""

import math
import os
import time
import zlib

from pymavlink import mavftp

from gcs_common import arm_in_guided, Failed, main, mav, VEHICLE
from read_mcap import topic_span

TAKEOFF_M = 5.0




def log_list(gcs, step, timeout_s=5.0):
    """LOG_REQUEST_LIST of every log; the LOG_ENTRYs until the one whose id is last_log_num."""
    entries = {}

    def got(m):
        if m.get_type() != "LOG_ENTRY" or not gcs.from_vehicle(m):
            return False
        entries[m.id] = m
        return m.id == m.last_log_num

    gcs.log("-> LOG_REQUEST_LIST 0..0xffff")
    gcs.conn.mav.log_request_list_send(*VEHICLE, 0, 0xFFFF)
    gcs.pump(got, timeout_s, step)
    out = [{"id": e.id, "num_logs": e.num_logs, "last_log_num": e.last_log_num, "size": e.size,
            "time_utc_set": e.time_utc > 0} for _, e in sorted(entries.items())]
    gcs.log(f"LOG_ENTRY x{len(out)}: {out}")
    return out


def log_download(gcs, log_id, size, step, timeout_s=60.0):
    """LOG_REQUEST_DATA for `size` bytes of log `log_id`, asking again from the first gap when the
    data stops for 0.5 s; returns the bytes and the chunk sizes seen."""
    chunks = {}
    counts = set()
    t0 = time.monotonic()
    end = t0 + timeout_s
    requests = 0

    def first_gap():
        ofs = 0
        while ofs < size and ofs in chunks:
            ofs += len(chunks[ofs]) or 1
        return ofs

    while True:
        ofs = first_gap()
        if ofs >= size:
            break
        if time.monotonic() > end:
            raise Failed(step, f"{ofs} of {size} bytes after {timeout_s} s")
        gcs.conn.mav.log_request_data_send(*VEHICLE, log_id, ofs, size - ofs)
        requests += 1
        last = time.monotonic()
        while time.monotonic() - last < 0.5:
            gcs.send_heartbeat_if_due()
            m = gcs.conn.recv_match(type="LOG_DATA", blocking=True, timeout=0.05)
            if m is None or m.id != log_id:
                continue
            last = time.monotonic()
            counts.add(m.count)
            chunks[m.ofs] = bytes(m.data[:m.count])
            if m.count < 90:
                break
    gcs.conn.mav.log_request_end_send(*VEHICLE)
    data = b"".join(chunks[o] for o in sorted(chunks))[:size]
    seconds = time.monotonic() - t0
    gcs.log(f"downloaded log {log_id}: {len(data)} bytes in {seconds:.2f} s, {requests} requests, "
            f"chunk sizes {sorted(counts)[:3]}..{max(counts) if counts else None}")
    return data, sorted(counts)


def past_end(gcs, log_id, size):
    """A request starting at the end of the log: the answer's (ofs, count), or None."""
    gcs.conn.mav.log_request_data_send(*VEHICLE, log_id, size, 90)
    try:
        m = gcs.wait_type("LOG_DATA", 2.0, "past end", lambda m: m.id == log_id)
    except Failed:
        return None
    gcs.conn.mav.log_request_end_send(*VEHICLE)
    return [m.ofs, m.count]


def ftp_session(gcs, params):
    """Lists, param.pck, CRC and a refused write over pymavlink's mavftp."""
    ftp = mavftp.MAVFTP(gcs.conn, target_system=VEHICLE[0], target_component=VEHICLE[1])
    out = {}
    for path in ["/", "/logs"]:
        ret = ftp.cmd_list([path])
        listing = sorted((e.name, e.is_dir, e.size_b) for e in (ret.directory_listing or [])
                         if e.name not in (".", ".."))
        gcs.log(f"FTP list {path}: error {ret.error_code}: {listing}")
        out[path] = {"error": ret.error_code, "entries": listing}
    got = {}

    def keep(fh):
        got["data"] = fh.read()

    t0 = time.monotonic()
    ftp.cmd_get(["@PARAM/param.pck"], callback=keep)
    ret = ftp.process_ftp_reply("OpenFileRO", timeout=10)
    data = got.get("data")
    gcs.log(f"FTP get @PARAM/param.pck: error {ret.error_code}, "
            f"{None if data is None else len(data)} bytes in {time.monotonic() - t0:.2f} s")
    pck = {"error": ret.error_code}
    if data is not None:
        decoded = mavftp.MAVFTP.ftp_param_decode(data)
        if decoded is None:
            raise Failed("param.pck", "pymavlink cannot decode it")
        values = {name.decode(): value for name, value, _ in decoded.params}
        pck["count"] = len(values)
        pck["same_names"] = sorted(values) == sorted(params)
        pck["same_values"] = all(math.isclose(values[n], params[n], rel_tol=1e-6, abs_tol=1e-6)
                                 for n in params if n in values)
        if not pck["same_values"]:
            bad = {n: (values[n], params[n]) for n in params
                   if n in values and not math.isclose(values[n], params[n], rel_tol=1e-6, abs_tol=1e-6)}
            gcs.log(f"param.pck values differing from PARAM_VALUE: {bad}")
    out["param_pck"] = pck
    return ftp, out


def raw_ftp(gcs, opcode, path, step):
    """One raw FTP request (session 0) and its answer: (opcode, error bytes)."""
    payload = bytearray(251)
    payload[0:2] = (7000).to_bytes(2, "little")
    payload[3] = opcode
    payload[4] = len(path)
    payload[12:12 + len(path)] = path.encode()
    gcs.conn.mav.file_transfer_protocol_send(0, *VEHICLE, payload)
    m = gcs.wait_type("FILE_TRANSFER_PROTOCOL", 3.0, step,
                      lambda m: m.payload[5] == opcode and m.payload[0] | (m.payload[1] << 8) == 7001)
    size = m.payload[4]
    answer = ["ACK" if m.payload[3] == 128 else "NAK", list(m.payload[12:12 + size])]
    gcs.log(f"FTP opcode {opcode} {path}: {answer}")
    return answer


def flight(gcs):
    gcs.identify()
    gcs.conn.mav.request_data_stream_send(*VEHICLE, mav.MAV_DATA_STREAM_ALL, 10, 1)
    arm_in_guided(gcs)
    gcs.command(mav.MAV_CMD_NAV_TAKEOFF, [0, 0, 0, 0, 0, 0, TAKEOFF_M], "take-off")
    gcs.pump(lambda m: gcs.rel_alt_m is not None and gcs.rel_alt_m >= TAKEOFF_M - 1.0, 30.0, "take-off")

    # Armed: a log list is refused.
    said_before = len(gcs.statustexts)
    gcs.conn.mav.log_request_list_send(*VEHICLE, 0, 0xFFFF)
    armed_entries = []

    def entry_seen(m):
        if m.get_type() == "LOG_ENTRY" and gcs.from_vehicle(m):
            armed_entries.append(m)
        return False

    try:
        gcs.pump(entry_seen, 1.5, "armed list")
    except Failed:
        pass
    gcs.results["armed_list"] = {"entries": len(armed_entries),
                                 "said": gcs.statustexts[said_before:]}
    gcs.log(f"armed LOG_REQUEST_LIST: {gcs.results['armed_list']}")

    gcs.set_mode_command("LAND", "land")
    gcs.pump(lambda m: gcs.heartbeat is not None and not gcs.armed, 60.0, "landed and disarmed")
    # The log is closed on disarming; give the writer a moment.
    gcs.quiet(1.0)

    entries = log_list(gcs, "log list")
    if not entries or entries[-1]["id"] == 0:
        raise Failed("log list", f"no logs: {entries}")
    gcs.results["entries"] = entries
    newest = entries[-1]
    limit = int(os.environ.get("DOWNLOAD_LIMIT", "0")) or newest["size"]
    size = min(limit, newest["size"])
    data, counts = log_download(gcs, newest["id"], size, "download")
    gcs.results["download"] = {"bytes": len(data), "chunk_sizes_max": max(counts),
                               "past_end": past_end(gcs, newest["id"], newest["size"])}
    log_dir = os.environ.get("LOG_DIR")
    if log_dir:
        names = sorted(n for n in os.listdir(log_dir) if n.endswith(".mcap"))
        on_disk = open(os.path.join(log_dir, names[-1]), "rb").read()

    params = gcs.fetch_params(timeout_s=10.0)
    gcs.results["params"] = {"count": len(params)}
    ftp, out = ftp_session(gcs, params)
    out["create_file"] = raw_ftp(gcs, 6, "/logs/kestrel-write-test.txt", "create")
    gcs.results["ftp"] = out
    if log_dir:
        want = zlib.crc32(on_disk, 0xFFFFFFFF) ^ 0xFFFFFFFF
        answer = raw_ftp(gcs, 14, "/logs/" + names[-1], "crc")
        got = int.from_bytes(bytes(answer[1]), "little") if answer[0] == "ACK" else None
        gcs.results["ftp"]["crc_equal"] = got == want

    # Last, as it reads files for a while without listening to the vehicle.
    if log_dir:
        local = os.path.join(os.environ.get("TMPDIR", "/tmp"), f"kestrel-downloaded-{os.getpid()}.mcap")
        with open(local, "wb") as f:
            f.write(data)
        try:
            span = topic_span(local, "vehicle_status")
        except Exception as e:  # the reference reader refusing the file is the finding
            raise Failed("mcap", f"{type(e).__name__}: {e}")
        finally:
            os.remove(local)
        gcs.results["on_disk"] = {
            "file": names[-1], "logs": len(names), "equal": on_disk == data,
            "topics": len(span["topics"]),
            "first_armed": (span["first"] or {}).get("armed"),
            "last_armed": (span["last"] or {}).get("armed"),
        }
        gcs.log(f"on disk: {gcs.results['on_disk']}")


main(flight, deadline_s=150.0)
