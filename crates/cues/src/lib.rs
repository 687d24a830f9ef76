//! splatseg `cues` stage (being written).
