//! FMI 2.0 layer (placeholder during bring-up).
