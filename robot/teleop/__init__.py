"""Manual driving: input → clamped Twist, the drive lock, the per-connection loop, the e-stop."""
