"""AprilTag turntable capture to a metric, coloured mesh (D3.1 section 3.3.3). Not built yet: its issue has not landed."""
