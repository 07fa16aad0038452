//! `kestrel report` on a flight recorded in-process from the default graph (`config/sim.toml`,
//! lockstep clock): the plots are real PNGs with content, the summary's numbers are plausible,
//! and bad input is refused with an error that says what was wrong.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::Duration;

use kestrel::flight_plots::{PLOT_SIZE_PX, PlotError, ReportSummary, SUMMARY_FILE, write_report};
use kestrel::recorder::Recorder;
use kestrel::{LoadedConfig, Registry, RunOptions, run};
use kestrel_proto::Time;
use kestrel_proto::messages::BaroSample;

#[path = "../src/cmd/report.rs"]
mod report_cmd;

/// A fresh scratch path for this test process.
fn scratch(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("kestrel-report-{}-{name}", std::process::id()))
}

/// A 20 s simulated flight (the vehicle at rest: the default graph has no controller yet),
/// recorded once for all tests.
fn recorded_log() -> &'static Path {
    static LOG: OnceLock<PathBuf> = OnceLock::new();
    LOG.get_or_init(|| {
        let path = scratch("sim.mcap");
        let config =
            LoadedConfig::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("config/sim.toml")).unwrap();
        let options = RunOptions {
            duration: Some(Duration::from_secs(20)),
            speedup: Some(0.0),
            record: Some(path.clone()),
            ..Default::default()
        };
        run(&config, &Registry::standard(), options).unwrap();
        path
    })
}

#[test]
fn a_simulated_flight_gives_every_plot_and_a_plausible_summary() {
    let out = scratch("plots");
    let summary = write_report(recorded_log(), &out).unwrap();
    println!("{summary}");

    let names: Vec<&str> =
        summary.plots.iter().map(|p| p.file.file_name().unwrap().to_str().unwrap()).collect();
    assert_eq!(
        names,
        [
            "position_north.png",
            "position_east.png",
            "position_zoom.png",
            "velocity_ned.png",
            "height.png",
            "climb_rate.png",
            "truth_position.png",
            "truth_velocity.png",
            "attitude_error.png",
        ]
    );
    for plot in &summary.plots {
        let image = png::decode(&std::fs::read(&plot.file).unwrap())
            .unwrap_or_else(|e| panic!("{}: {e}", plot.file.display()));
        assert_eq!((image.width, image.height), PLOT_SIZE_PX, "{}", plot.file.display());
        assert_eq!((plot.width_px, plot.height_px), PLOT_SIZE_PX);
        let luma = image.luma();
        let mean = luma.iter().map(|&l| f64::from(l)).sum::<f64>() / luma.len() as f64;
        let variance = luma.iter().map(|&l| (f64::from(l) - mean).powi(2)).sum::<f64>() / luma.len() as f64;
        assert!(variance > 200.0, "{} looks blank (luma variance {variance:.1})", plot.file.display());
        let inked = luma.iter().filter(|&&l| l < 200).count() as f64 / luma.len() as f64;
        assert!(
            (0.01..0.5).contains(&inked),
            "{}: {:.1} % of pixels inked",
            plot.file.display(),
            inked * 100.0
        );
        // The title is text in the top band: dark pixels there mean the embedded font rendered.
        let title_band = &luma[..image.width as usize * 36];
        assert!(
            title_band.iter().filter(|&&l| l < 100).count() > 200,
            "{}: no title text drawn",
            plot.file.display()
        );
    }

    let gps = summary.vs_gps.as_ref().expect("GPS errors");
    assert!(gps.samples > 80, "{gps:?}");
    assert!(gps.rms_horizontal_m.is_finite() && gps.rms_horizontal_m < 3.0, "{gps:?}");
    assert!(gps.rms_velocity_north_m_s < 0.5 && gps.rms_velocity_down_m_s < 0.5, "{gps:?}");
    let latency = summary.gps_latency_ms.unwrap();
    assert!((latency - 220.0).abs() < 10.0, "GPS lags 220 ms in the simulator, measured {latency} ms");
    let baro = summary.vs_baro.as_ref().expect("barometer errors");
    assert!(baro.samples > 150 && baro.rms_height_m < 2.0, "{baro:?}");
    assert!(baro.rms_climb_rate_m_s.is_some_and(|r| r < 2.0), "{baro:?}");
    let truth = summary.vs_truth.as_ref().expect("ground-truth errors");
    assert!(truth.samples > 800, "{truth:?}");
    assert!(truth.rms_horizontal_m < 1.0 && truth.rms_vertical_m < 1.0, "{truth:?}");
    assert!(truth.rms_velocity_m_s < 0.3, "{truth:?}");
    assert!(truth.rms_roll_pitch_deg.is_some_and(|d| d < 2.0), "{truth:?}");
    assert!(truth.rms_yaw_deg.is_some_and(|d| d < 5.0), "{truth:?}");
    assert!((summary.duration_s - 20.0).abs() < 0.5, "{}", summary.duration_s);

    let written: ReportSummary =
        serde_json::from_slice(&std::fs::read(out.join(SUMMARY_FILE)).unwrap()).unwrap();
    assert_eq!(written, summary);
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_missing_log_is_named_in_the_error() {
    let missing = scratch("no-such-flight.mcap");
    let error = write_report(&missing, &scratch("unused")).unwrap_err();
    assert!(matches!(error, PlotError::Log(_)), "{error:?}");
    assert!(error.to_string().contains(&*missing.to_string_lossy()), "{error}");
    assert!(!scratch("unused").exists(), "no output directory for a failed report");
}

#[test]
fn a_log_without_the_estimate_says_what_is_missing() {
    let path = scratch("baro-only.mcap");
    let recorder = Recorder::create(&path).unwrap();
    let baro = recorder.channel::<BaroSample>("baro").unwrap();
    for i in 0..20u64 {
        let time = Time::from_micros(i * 100_000);
        baro.record(
            time,
            &BaroSample { time, pressure_pa: 101_000.0, altitude_m: 20.0, temperature_c: 25.0 },
        );
    }
    recorder.finish().unwrap();

    let error = write_report(&path, &scratch("baro-only")).unwrap_err();
    let text = error.to_string();
    let _ = std::fs::remove_file(&path);
    assert!(matches!(error, PlotError::MissingTopic { type_name: "kestrel.NavState", .. }), "{error:?}");
    assert!(text.contains(&*path.to_string_lossy()) && text.contains("baro (kestrel.BaroSample)"), "{text}");
}

#[test]
fn the_command_parses_its_arguments_and_reports_errors_as_text() {
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: report_cmd::ReportArgs,
    }
    let cli = Cli::try_parse_from(["kestrel-report", "flight.mcap", "--out", "plots"]).unwrap();
    assert_eq!(
        (cli.args.log.as_path(), cli.args.out.as_path()),
        (Path::new("flight.mcap"), Path::new("plots"))
    );
    assert!(Cli::try_parse_from(["kestrel-report", "flight.mcap"]).is_err(), "--out is required");

    let missing = scratch("cli-missing.mcap");
    let args = report_cmd::ReportArgs { log: missing.clone(), out: scratch("cli-out") };
    let error = report_cmd::run(args).unwrap_err();
    assert!(error.contains(&*missing.to_string_lossy()), "{error}");
}

/// A minimal PNG reader (8-bit greyscale, RGB or RGBA, not interlaced) with its own inflate, so
/// the test checks the files independently of the encoder that wrote them.
mod png {
    pub struct Image {
        pub width: u32,
        pub height: u32,
        channels: usize,
        pixels: Vec<u8>,
    }

    impl Image {
        /// Per-pixel luma (ITU-R BT.601), 0–255.
        pub fn luma(&self) -> Vec<u8> {
            self.pixels
                .chunks(self.channels)
                .map(|p| match p {
                    [r, g, b, ..] => {
                        ((299 * u32::from(*r) + 587 * u32::from(*g) + 114 * u32::from(*b)) / 1000) as u8
                    }
                    [grey, ..] => *grey,
                    [] => 0,
                })
                .collect()
        }
    }

    pub fn decode(bytes: &[u8]) -> Result<Image, String> {
        let body = bytes.strip_prefix(b"\x89PNG\r\n\x1a\n").ok_or("no PNG signature")?;
        let (mut header, mut compressed, mut rest) = (None, Vec::new(), body);
        while rest.len() >= 12 {
            let length = u32::from_be_bytes(rest[..4].try_into().unwrap()) as usize;
            let kind = &rest[4..8];
            let data = rest.get(8..8 + length).ok_or("truncated chunk")?;
            match kind {
                b"IHDR" => header = Some(data.to_vec()),
                b"IDAT" => compressed.extend_from_slice(data),
                b"IEND" => break,
                _ => {}
            }
            rest = &rest[12 + length..];
        }
        let header = header.ok_or("no IHDR")?;
        let width = u32::from_be_bytes(header[0..4].try_into().unwrap());
        let height = u32::from_be_bytes(header[4..8].try_into().unwrap());
        let channels = match (header[8], header[9], header[12]) {
            (8, 0, 0) => 1,
            (8, 2, 0) => 3,
            (8, 6, 0) => 4,
            other => return Err(format!("unsupported depth/colour/interlace {other:?}")),
        };
        let raw = inflate(compressed.get(2..).ok_or("empty zlib stream")?)?;
        let stride = width as usize * channels;
        if raw.len() != height as usize * (stride + 1) {
            return Err(format!("{} bytes of image data for {width}×{height}", raw.len()));
        }
        let mut pixels = vec![0u8; height as usize * stride];
        for (y, line) in raw.chunks(stride + 1).enumerate() {
            let (done, current) = pixels.split_at_mut(y * stride);
            let previous = done.get(done.len().saturating_sub(stride)..).filter(|_| y > 0);
            for x in 0..stride {
                let a = if x >= channels { current[x - channels] } else { 0 };
                let b = previous.map_or(0, |p| p[x]);
                let c = if x >= channels { previous.map_or(0, |p| p[x - channels]) } else { 0 };
                let predicted = match line[0] {
                    0 => 0,
                    1 => a,
                    2 => b,
                    3 => ((u16::from(a) + u16::from(b)) / 2) as u8,
                    4 => paeth(a, b, c),
                    f => return Err(format!("filter {f}")),
                };
                current[x] = line[x + 1].wrapping_add(predicted);
            }
        }
        Ok(Image { width, height, channels, pixels })
    }

    fn paeth(a: u8, b: u8, c: u8) -> u8 {
        let p = i16::from(a) + i16::from(b) - i16::from(c);
        let (pa, pb, pc) = ((p - i16::from(a)).abs(), (p - i16::from(b)).abs(), (p - i16::from(c)).abs());
        if pa <= pb && pa <= pc {
            a
        } else if pb <= pc {
            b
        } else {
            c
        }
    }

    struct Bits<'a> {
        data: &'a [u8],
        position: usize,
    }

    impl Bits<'_> {
        fn take(&mut self, n: u32) -> Result<u32, String> {
            let mut value = 0;
            for i in 0..n {
                let byte = self.data.get(self.position / 8).ok_or("deflate stream ends early")?;
                value |= u32::from((byte >> (self.position % 8)) & 1) << i;
                self.position += 1;
            }
            Ok(value)
        }
    }

    /// Canonical Huffman code: codes per length and symbols in code order.
    struct Huffman {
        counts: [u16; 16],
        symbols: Vec<u16>,
    }

    impl Huffman {
        fn new(lengths: &[u8]) -> Huffman {
            let mut counts = [0u16; 16];
            for &l in lengths {
                counts[usize::from(l)] += 1;
            }
            counts[0] = 0;
            let mut symbols: Vec<u16> =
                (0..lengths.len() as u16).filter(|&s| lengths[usize::from(s)] > 0).collect();
            symbols.sort_by_key(|&s| lengths[usize::from(s)]);
            Huffman { counts, symbols }
        }

        fn decode(&self, bits: &mut Bits) -> Result<u16, String> {
            let (mut code, mut first, mut index) = (0i32, 0i32, 0i32);
            for length in 1..16 {
                code |= bits.take(1)? as i32;
                let count = i32::from(self.counts[length]);
                if code - first < count {
                    return Ok(self.symbols[(index + code - first) as usize]);
                }
                index += count;
                first = (first + count) << 1;
                code <<= 1;
            }
            Err("bad Huffman code".to_owned())
        }
    }

    const LENGTH_BASE: [u16; 29] = [
        3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163,
        195, 227, 258,
    ];
    const LENGTH_EXTRA: [u8; 29] =
        [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0];
    const DISTANCE_BASE: [u16; 30] = [
        1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025, 1537, 2049,
        3073, 4097, 6145, 8193, 12289, 16385, 24577,
    ];
    const DISTANCE_EXTRA: [u8; 30] =
        [0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13];
    const CODE_LENGTH_ORDER: [usize; 19] = [16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15];

    /// RFC 1951 DEFLATE.
    fn inflate(data: &[u8]) -> Result<Vec<u8>, String> {
        let (mut bits, mut out) = (Bits { data, position: 0 }, Vec::new());
        loop {
            let last = bits.take(1)? == 1;
            match bits.take(2)? {
                0 => {
                    bits.position = bits.position.div_ceil(8) * 8;
                    let length = bits.take(16)? as usize;
                    bits.take(16)?;
                    let start = bits.position / 8;
                    out.extend_from_slice(data.get(start..start + length).ok_or("stored block ends early")?);
                    bits.position += length * 8;
                }
                1 => {
                    let mut lengths = [8u8; 288];
                    lengths[144..256].fill(9);
                    lengths[256..280].fill(7);
                    inflate_block(&mut bits, &mut out, &Huffman::new(&lengths), &Huffman::new(&[5; 30]))?;
                }
                2 => {
                    let literals = bits.take(5)? as usize + 257;
                    let distances = bits.take(5)? as usize + 1;
                    let mut code_lengths = [0u8; 19];
                    for &i in CODE_LENGTH_ORDER.iter().take(bits.take(4)? as usize + 4) {
                        code_lengths[i] = bits.take(3)? as u8;
                    }
                    let code = Huffman::new(&code_lengths);
                    let mut lengths = Vec::with_capacity(literals + distances);
                    while lengths.len() < literals + distances {
                        let (value, repeat) = match code.decode(&mut bits)? {
                            s @ 0..16 => (s as u8, 1),
                            16 => (*lengths.last().ok_or("repeat with no length")?, 3 + bits.take(2)?),
                            17 => (0, 3 + bits.take(3)?),
                            _ => (0, 11 + bits.take(7)?),
                        };
                        lengths.extend(std::iter::repeat_n(value, repeat as usize));
                    }
                    let (literal, distance) = lengths.split_at(literals);
                    inflate_block(&mut bits, &mut out, &Huffman::new(literal), &Huffman::new(distance))?;
                }
                _ => return Err("reserved block type".to_owned()),
            }
            if last {
                return Ok(out);
            }
        }
    }

    fn inflate_block(
        bits: &mut Bits,
        out: &mut Vec<u8>,
        literal: &Huffman,
        distance: &Huffman,
    ) -> Result<(), String> {
        loop {
            let symbol = usize::from(literal.decode(bits)?);
            match symbol {
                0..256 => out.push(symbol as u8),
                256 => return Ok(()),
                _ => {
                    let i = symbol - 257;
                    let base = *LENGTH_BASE.get(i).ok_or("bad length symbol")?;
                    let length = usize::from(base) + bits.take(u32::from(LENGTH_EXTRA[i]))? as usize;
                    let d = usize::from(distance.decode(bits)?);
                    let base = *DISTANCE_BASE.get(d).ok_or("bad distance symbol")?;
                    let back = usize::from(base) + bits.take(u32::from(DISTANCE_EXTRA[d]))? as usize;
                    let start = out.len().checked_sub(back).ok_or("distance before the start")?;
                    for k in 0..length {
                        out.push(out[start + k]);
                    }
                }
            }
        }
    }
}
