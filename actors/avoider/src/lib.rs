//! Fuzzy inference engine and the obstacle avoider.
