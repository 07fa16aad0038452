//! The uploaded plans on disk, so that a restart keeps them: one file per plan type
//! (`mission.waypoints`, `fence.waypoints`, `rally.waypoints`) in the vehicle's state directory,
//! in the "QGC WPL 110" text format MAVProxy and QGroundControl read and write (one item a line:
//! seq, current, frame, command, param1..4, x, y, z, autocontinue; tab separated). Latitude and
//! longitude of global frames are written in degrees with seven decimals, the other numbers in
//! the shortest form that reads back to the same `f32`, so a plan read back is the plan
//! uploaded, field for field (`tests::a_plan_written_reads_back_field_for_field`).
//!
//! Each file is replaced atomically by a writer thread of its own (`ParamWriter`, the link's
//! one atomic writer), never on the receive path. A file that does not read is an error naming
//! the file and line; the caller then starts with no plan of that type rather than part of one.

use std::path::{Path, PathBuf};

use kestrel_proto::geo::{deg_e7, deg_from_e7};
use mavlink::dialects::ardupilotmega::{MISSION_ITEM_INT_DATA, MavCmd, MavFrame, MavMissionType};
use num_traits::FromPrimitive;

use super::items::is_global;
use crate::transport::ParamWriter;

/// First line of every plan file (MAVProxy's and QGroundControl's waypoint file format).
const HEADER: &str = "QGC WPL 110";

/// The plan types kept, with their file names.
pub const PLAN_FILES: [(MavMissionType, &str); 3] = [
    (MavMissionType::MAV_MISSION_TYPE_MISSION, "mission.waypoints"),
    (MavMissionType::MAV_MISSION_TYPE_FENCE, "fence.waypoints"),
    (MavMissionType::MAV_MISSION_TYPE_RALLY, "rally.waypoints"),
];

/// Why a plan file was not read: the file, the line (from 1; 0 for the file as a whole) and
/// what was wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}:{line}: {what}")]
pub struct PlanFileError {
    pub file: PathBuf,
    pub line: usize,
    pub what: String,
}

/// The text of a plan file holding `items`.
pub fn render(items: &[MISSION_ITEM_INT_DATA]) -> String {
    let mut text = format!("{HEADER}\n");
    for m in items {
        let (x, y) = if is_global(m.frame) {
            (format!("{:.7}", deg_from_e7(f64::from(m.x))), format!("{:.7}", deg_from_e7(f64::from(m.y))))
        } else {
            (m.x.to_string(), m.y.to_string())
        };
        text.push_str(&format!(
            "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{x}\t{y}\t{}\t{}\n",
            m.seq,
            m.current,
            m.frame as u8,
            m.command as u16,
            m.param1,
            m.param2,
            m.param3,
            m.param4,
            m.z,
            m.autocontinue
        ));
    }
    text
}

/// The items of a plan file's `text` (of type `t`); `file` names it in an error.
pub fn parse(
    file: &Path,
    text: &str,
    t: MavMissionType,
) -> Result<Vec<MISSION_ITEM_INT_DATA>, PlanFileError> {
    let error = |line: usize, what: String| PlanFileError { file: file.to_owned(), line, what };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, first)) if first.trim() == HEADER => {}
        _ => return Err(error(1, format!("not a waypoint file: the first line must be \"{HEADER}\""))),
    }
    let mut items = Vec::new();
    for (i, line) in lines.filter(|(_, l)| !l.trim().is_empty()) {
        let n = i + 1;
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() != 12 {
            return Err(error(n, format!("{} fields, a waypoint line has 12", f.len())));
        }
        let int = |k: usize, name: &str| {
            f[k].parse::<i64>().map_err(|_| error(n, format!("{name} \"{}\" is not a whole number", f[k])))
        };
        let real = |k: usize, name: &str| {
            f[k].parse::<f32>().map_err(|_| error(n, format!("{name} \"{}\" is not a number", f[k])))
        };
        let seq = int(0, "seq")?;
        if seq != items.len() as i64 {
            return Err(error(n, format!("seq {seq}, expected {}", items.len())));
        }
        let frame = MavFrame::from_i64(int(2, "frame")?)
            .ok_or_else(|| error(n, format!("unknown frame {}", f[2])))?;
        let command = MavCmd::from_i64(int(3, "command")?)
            .ok_or_else(|| error(n, format!("unknown command {}", f[3])))?;
        let coordinate = |k: usize, name: &str| -> Result<i32, PlanFileError> {
            if is_global(frame) {
                let deg = f[k]
                    .parse::<f64>()
                    .ok()
                    .filter(|d| d.is_finite() && d.abs() <= if k == 8 { 90.0 } else { 180.0 })
                    .ok_or_else(|| error(n, format!("{name} \"{}\" is not a latitude/longitude", f[k])))?;
                Ok(deg_e7(deg))
            } else {
                i32::try_from(int(k, name)?).map_err(|_| error(n, format!("{name} {} out of range", f[k])))
            }
        };
        let small = |k: usize, name: &str| -> Result<u8, PlanFileError> {
            u8::try_from(int(k, name)?).map_err(|_| error(n, format!("{name} {} out of range", f[k])))
        };
        items.push(MISSION_ITEM_INT_DATA {
            seq: u16::try_from(seq).map_err(|_| error(n, "too many items".into()))?,
            current: small(1, "current")?,
            frame,
            command,
            param1: real(4, "param1")?,
            param2: real(5, "param2")?,
            param3: real(6, "param3")?,
            param4: real(7, "param4")?,
            x: coordinate(8, "x")?,
            y: coordinate(9, "y")?,
            z: real(10, "z")?,
            autocontinue: small(11, "autocontinue")?,
            mission_type: t,
            target_system: 0,
            target_component: 0,
        });
    }
    Ok(items)
}

/// Where the plans live, and a writer for each file.
pub struct PlanStore {
    dir: PathBuf,
    writers: Vec<(MavMissionType, ParamWriter)>,
}

impl std::fmt::Debug for PlanStore {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlanStore").field("dir", &self.dir).finish_non_exhaustive()
    }
}

impl PlanStore {
    /// A store in `dir` (made if missing), its writer threads started.
    pub fn open(dir: &Path) -> std::io::Result<PlanStore> {
        std::fs::create_dir_all(dir)?;
        let writers = PLAN_FILES
            .iter()
            .map(|&(t, name)| ParamWriter::to_file(dir.join(name)).map(|w| (t, w)))
            .collect::<std::io::Result<_>>()?;
        Ok(PlanStore { dir: dir.to_owned(), writers })
    }

    /// The file of plan type `t`.
    pub fn file(&self, t: MavMissionType) -> Option<PathBuf> {
        PLAN_FILES.iter().find(|(k, _)| *k == t).map(|(_, name)| self.dir.join(name))
    }

    /// The stored plan of type `t`: `Ok(None)` when there is no file.
    pub fn load(&self, t: MavMissionType) -> Result<Option<Vec<MISSION_ITEM_INT_DATA>>, PlanFileError> {
        let Some(path) = self.file(t) else { return Ok(None) };
        match std::fs::read_to_string(&path) {
            Ok(text) => parse(&path, &text, t).map(Some),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(PlanFileError { file: path, line: 0, what: e.to_string() }),
        }
    }

    /// Queues `items` as the new plan of type `t` (written off the caller's thread).
    pub fn save(&self, t: MavMissionType, items: &[MISSION_ITEM_INT_DATA]) {
        if let Some((_, w)) = self.writers.iter().find(|(k, _)| *k == t) {
            w.submit(render(items));
        }
    }

    /// Writes what is pending and stops the writers (at shutdown).
    pub fn finish(&self) {
        for (_, w) in &self.writers {
            w.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn items() -> Vec<MISSION_ITEM_INT_DATA> {
        let item = |seq: u16, command, frame, x, y, z| MISSION_ITEM_INT_DATA {
            seq,
            command,
            frame,
            x,
            y,
            z,
            param1: 0.1 * f32::from(seq),
            param4: f32::NAN,
            autocontinue: 1,
            mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
            ..MISSION_ITEM_INT_DATA::default()
        };
        vec![
            item(
                0,
                MavCmd::MAV_CMD_NAV_WAYPOINT,
                MavFrame::MAV_FRAME_GLOBAL_INT,
                67_971_000,
                799_017_000,
                20.0,
            ),
            item(1, MavCmd::MAV_CMD_NAV_TAKEOFF, MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0, 0, 10.3),
            item(
                2,
                MavCmd::MAV_CMD_NAV_WAYPOINT,
                MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                -67_971_234,
                -1_799_999_999,
                12.25,
            ),
            item(3, MavCmd::MAV_CMD_DO_CHANGE_SPEED, MavFrame::MAV_FRAME_MISSION, 0, -5, 0.0),
        ]
    }

    fn same(a: &MISSION_ITEM_INT_DATA, b: &MISSION_ITEM_INT_DATA) -> bool {
        let f = |v: f32| v.to_bits();
        (a.seq, a.current, a.frame, a.command, a.x, a.y, a.autocontinue, a.mission_type)
            == (b.seq, b.current, b.frame, b.command, b.x, b.y, b.autocontinue, b.mission_type)
            && [a.param1, a.param2, a.param3, a.param4, a.z].map(f)
                == [b.param1, b.param2, b.param3, b.param4, b.z].map(f)
    }

    #[test]
    fn a_plan_written_reads_back_field_for_field() {
        let text = render(&items());
        assert!(
            text.starts_with("QGC WPL 110\n0\t0\t5\t16\t0\t0\t0\tNaN\t6.7971000\t79.9017000\t20\t1\n"),
            "{text}"
        );
        let back = parse(Path::new("m"), &text, MavMissionType::MAV_MISSION_TYPE_MISSION).expect("reads");
        assert_eq!(back.len(), 4);
        for (a, b) in items().iter().zip(&back) {
            assert!(same(a, b), "{a:?} != {b:?}");
        }
        assert_eq!(
            parse(Path::new("m"), "QGC WPL 110\n", MavMissionType::MAV_MISSION_TYPE_RALLY),
            Ok(Vec::new())
        );
    }

    #[test]
    fn a_corrupt_file_is_an_error_naming_the_file_and_line() {
        let good = render(&items());
        let mut lines: Vec<&str> = good.lines().collect();
        let cases = [
            (0, "QGC WPL 100", 1, "not a waypoint file"),
            (3, "2\t0\t3\t16\t0\t0\t0\t0\t6.79\t79.9\t10", 4, "11 fields"),
            (3, "2\t0\t3\t16\t0\t0\t0\tx\t6.79\t79.9\t10\t1", 4, "param4 \"x\""),
            (2, "5\t0\t3\t22\t0\t0\t0\t0\t0\t0\t10\t1", 3, "seq 5, expected 1"),
            (2, "1\t0\t3\t22\t0\t0\t0\t0\t95.5\t0\t10\t1", 3, "not a latitude"),
            (2, "1\t0\t3\t65000\t0\t0\t0\t0\t0\t0\t10\t1", 3, "unknown command"),
        ];
        for (at, bad, line, what) in cases {
            let keep = lines[at];
            lines[at] = bad;
            let text = lines.join("\n");
            let e =
                parse(Path::new("/state/mission.waypoints"), &text, MavMissionType::MAV_MISSION_TYPE_MISSION)
                    .expect_err(bad);
            assert_eq!((e.line, e.file.as_path()), (line, Path::new("/state/mission.waypoints")), "{e}");
            assert!(e.what.contains(what), "{e}");
            assert!(e.to_string().starts_with(&format!("/state/mission.waypoints:{line}: ")), "{e}");
            lines[at] = keep;
        }
    }

    #[test]
    fn the_store_writes_each_plan_to_its_file_and_reads_it_back() {
        let dir = std::env::temp_dir().join(format!("kestrel-plan-store-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let store = PlanStore::open(&dir).expect("open");
        assert_eq!(store.load(MavMissionType::MAV_MISSION_TYPE_FENCE), Ok(None));
        store.save(MavMissionType::MAV_MISSION_TYPE_MISSION, &items());
        store.finish();
        let back = store.load(MavMissionType::MAV_MISSION_TYPE_MISSION).expect("reads").expect("stored");
        assert!(items().iter().zip(&back).all(|(a, b)| same(a, b)) && back.len() == 4);
        let _ = std::fs::remove_dir_all(&dir);
    }
}
