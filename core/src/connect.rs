//! Connection of bubble centres (placeholder; being written).
