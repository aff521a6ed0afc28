"""What the robot says about itself: its state machine (SMACH introspection) and its diagnostics."""
