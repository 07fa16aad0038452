//! Real-time factor of the simulator: one simulated second of hover (400 IMU ticks, two
//! physics substeps each, every sensor, ground truth and battery) per iteration.
//!
//! Criterion reports the wall time per simulated second; the real-time factor is its inverse,
//! printed at the end (`cargo bench -p kestrel-sim --bench realtime_factor`).

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::Criterion;
use kestrel_proto::Time;
use kestrel_proto::messages::{ActuatorOutputs, MAX_MOTORS};
use kestrel_sim::{
    InitialState, RigidBodyState, SimOptions, Simulator, VehicleParams, World, hover_throttle,
};

fn hovering() -> Simulator {
    let vehicle = VehicleParams::default();
    let actuators =
        ActuatorOutputs { time: Time::ZERO, armed: true, motors: [hover_throttle(&vehicle); MAX_MOTORS] };
    let body = RigidBodyState { position_ned_m: [0.0, 0.0, -10.0].into(), ..RigidBodyState::default() };
    let options = SimOptions { initial: InitialState { body, actuators }, ..SimOptions::default() };
    Simulator::new(vehicle, World::default(), options).expect("default vehicle and world are valid")
}

/// Advances one simulated second and consumes every output, as the actor does.
fn one_second(sim: &mut Simulator) {
    let end = Time(sim.time().0 + 1_000_000);
    while sim.time() < end {
        sim.step();
        for output in sim.drain() {
            black_box(output);
        }
    }
}

fn main() {
    let mut criterion = Criterion::default().configure_from_args();
    let mut sim = hovering();
    criterion.bench_function("sim: 1 s of hover at 400 Hz", |b| b.iter(|| one_second(&mut sim)));
    criterion.final_summary();

    let mut sim = hovering();
    let simulated_s = 60;
    let started = Instant::now();
    for _ in 0..simulated_s {
        one_second(&mut sim);
    }
    let wall = started.elapsed().max(Duration::from_nanos(1));
    println!(
        "real-time factor: {:.0}x ({simulated_s} s simulated in {:.1} ms of wall time)",
        f64::from(simulated_s) / wall.as_secs_f64(),
        wall.as_secs_f64() * 1e3
    );
}
