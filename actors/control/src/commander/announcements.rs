//! What the commander says to the ground station: refusals and notices, each the newest text
//! of the status (`VehicleStatus::last_refusal`, sent by the link as a STATUSTEXT) and counted
//! (`VehicleStatus::refusals`), so that a text repeated word for word is still told apart.

/// The newest refusal or notice and how many there were.
#[derive(Debug, Default)]
pub(crate) struct Announcements {
    last: Option<String>,
    /// Refusals and notices so far; wraps (the link compares it for a change only).
    count: u32,
}

impl Announcements {
    /// Records `text` as the newest refusal or notice.
    pub fn announce(&mut self, text: String) {
        self.count = self.count.wrapping_add(1);
        self.last = Some(text);
    }

    /// The newest refusal or notice, if any.
    pub fn last(&self) -> Option<&str> {
        self.last.as_deref()
    }

    /// Refusals and notices so far (wrapping).
    pub fn count(&self) -> u32 {
        self.count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_newest_text_is_kept_and_every_one_is_counted_even_a_repeat() {
        let mut a = Announcements::default();
        assert_eq!((a.last(), a.count()), (None, 0));
        a.announce("flip refused: only in ACRO".into());
        a.announce("flip refused: only in ACRO".into());
        assert_eq!((a.last(), a.count()), (Some("flip refused: only in ACRO"), 2));
        a.announce("home set".into());
        assert_eq!(a.last(), Some("home set"));
    }

    #[test]
    fn the_count_wraps_instead_of_overflowing() {
        let mut a = Announcements { last: None, count: u32::MAX };
        a.announce("again".into());
        assert_eq!(a.count(), 0);
    }
}
