//! mavlink-router's routing rules, without sockets: a message addressed to a system goes to the
//! links where that system has been heard, a broadcast goes everywhere, and nothing goes back to
//! the link it came from.

use std::collections::{BTreeMap, BTreeSet};

/// A link: one serial port, one TCP connection, one UDP peer.
pub type LinkId = u32;

/// Where each system has been heard.
#[derive(Debug, Default)]
pub struct Router {
    seen: BTreeMap<u32, BTreeSet<LinkId>>,
    links: BTreeSet<LinkId>,
    /// Addressed messages dropped because their target was never heard.
    unroutable: u64,
}

impl Router {
    /// A router with no links.
    pub fn new() -> Router {
        Router::default()
    }

    /// Registers a link.
    pub fn add_link(&mut self, link: LinkId) {
        self.links.insert(link);
    }

    /// Forgets a link (a closed TCP connection, a UDP peer gone quiet).
    pub fn remove_link(&mut self, link: LinkId) {
        self.links.remove(&link);
        for links in self.seen.values_mut() {
            links.remove(&link);
        }
        self.seen.retain(|_, links| !links.is_empty());
    }

    /// Notes that `system_id` spoke on `link`.
    pub fn learn(&mut self, link: LinkId, system_id: u32) {
        self.seen.entry(system_id).or_default().insert(link);
    }

    /// Whether `system_id` has been heard on any link.
    pub fn knows(&self, system_id: u32) -> bool {
        self.seen.contains_key(&system_id)
    }

    /// Links a message from `from` (`None`: from this vehicle) addressed to `target_system`
    /// (`None` or 0: broadcast) must go to.
    pub fn destinations(&mut self, from: Option<LinkId>, target_system: Option<u8>) -> Vec<LinkId> {
        let candidates: Vec<LinkId> = match target_system.filter(|&t| t != 0) {
            None => self.links.iter().copied().collect(),
            Some(t) => match self.seen.get(&u32::from(t)) {
                Some(links) => links.iter().copied().collect(),
                None => {
                    self.unroutable += 1;
                    Vec::new()
                }
            },
        };
        candidates.into_iter().filter(|&l| Some(l) != from).collect()
    }

    /// Addressed messages dropped so far because their target was never heard.
    pub fn unroutable(&self) -> u64 {
        self.unroutable
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn router() -> Router {
        let mut r = Router::new();
        for l in [1, 2, 3] {
            r.add_link(l);
        }
        r.learn(1, 255); // a GCS on link 1
        r.learn(2, 42); // a companion on link 2
        r
    }

    #[test]
    fn broadcasts_go_everywhere_but_back() {
        let mut r = router();
        assert_eq!(r.destinations(Some(1), None), vec![2, 3]);
        assert_eq!(r.destinations(Some(2), Some(0)), vec![1, 3]);
        assert_eq!(r.destinations(None, None), vec![1, 2, 3]);
    }

    #[test]
    fn addressed_messages_go_where_the_target_was_seen() {
        let mut r = router();
        assert_eq!(r.destinations(Some(2), Some(255)), vec![1]);
        assert_eq!(r.destinations(None, Some(42)), vec![2]);
        assert_eq!(r.destinations(Some(1), Some(255)), Vec::<LinkId>::new());
        assert_eq!(r.destinations(Some(1), Some(77)), Vec::<LinkId>::new());
        assert_eq!(r.unroutable(), 1);
    }

    #[test]
    fn removed_links_are_forgotten() {
        let mut r = router();
        r.remove_link(1);
        assert!(!r.knows(255));
        assert_eq!(r.destinations(None, None), vec![2, 3]);
    }
}
