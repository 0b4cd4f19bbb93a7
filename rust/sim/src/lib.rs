//! Simulator of phone logs (being implemented).
