//! pdr (being implemented).

use serde::{Deserialize, Serialize};

/// Parameters of the pdr subsystem; every field documented with unit and default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct PdrConfig {}

impl PdrConfig {
    /// Checks every field's range; errors name the field.
    pub fn validate(&self) -> crate::Result<()> {
        Ok(())
    }
}
