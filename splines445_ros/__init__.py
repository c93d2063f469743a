"""splines445_ros: jerk-continuous joint trajectories through waypoints (Petrinec & Kovacic)."""
