//! Element quality (placeholder; being written).
