//! The name serde gives an enum variant (`FailsafeCause::BatteryLow` → `battery_low`), the way
//! configs and logs spell it, for status lines and reports.

use serde::Serialize;

/// `value`'s serialised name, or its JSON text when it is not a plain string.
pub fn serde_name<T: Serialize>(value: &T) -> String {
    match serde_json::to_value(value) {
        Ok(serde_json::Value::String(s)) => s,
        Ok(other) => other.to_string(),
        Err(e) => format!("unserialisable: {e}"),
    }
}
