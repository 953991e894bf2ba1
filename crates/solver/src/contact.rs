//! Which contact, in the candidate's labelling.

use std::fmt;

/// Which contact, in the candidate's labelling.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Contact {
    /// `contact_1`.
    First,
    /// `contact_2`.
    Second,
}

impl Contact {
    /// The other contact.
    pub fn other(self) -> Contact {
        match self {
            Contact::First => Contact::Second,
            Contact::Second => Contact::First,
        }
    }
}

impl fmt::Display for Contact {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Contact::First => "contact_1",
            Contact::Second => "contact_2",
        })
    }
}
