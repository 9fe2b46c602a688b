"""Contact pipeline: broad phase -> narrow phase -> persistent contact set -> law."""
