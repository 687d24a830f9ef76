//! splatseg `edit` stage (being written).
