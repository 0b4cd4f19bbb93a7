//! Readers and writers of phone logs (being implemented).
