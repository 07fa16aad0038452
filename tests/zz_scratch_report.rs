#[test]
fn scratch() {
    let log = std::env::var("LOG").unwrap();
    let out = std::env::var("OUT").unwrap();
    let t = std::time::Instant::now();
    let s =
        kestrel::flight_plots::write_report(std::path::Path::new(&log), std::path::Path::new(&out)).unwrap();
    println!("{s}\n{:?}", t.elapsed());
}
