//! The median and 95th percentile of a set of latency samples, as the flight report and the
//! Zenoh bridge print them: the sample at rank `round((n − 1)·q)` of the sorted set, so both
//! read alike.

/// `(p50, p95)` of `samples` (any order, any unit), or `None` without samples.
pub fn p50_p95(samples: &[f64]) -> Option<(f64, f64)> {
    if samples.is_empty() {
        return None;
    }
    let mut sorted = samples.to_vec();
    sorted.sort_by(f64::total_cmp);
    let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize];
    Some((at(0.5), at(0.95)))
}

#[cfg(test)]
mod tests {
    use super::p50_p95;

    #[test]
    fn ranks_round_into_the_sorted_samples() {
        assert_eq!(p50_p95(&[]), None);
        assert_eq!(p50_p95(&[7.0]), Some((7.0, 7.0)));
        let shuffled: Vec<f64> = (0..21).map(|i| f64::from((i * 8) % 21)).collect();
        assert_eq!(p50_p95(&shuffled), Some((10.0, 19.0)));
    }
}
