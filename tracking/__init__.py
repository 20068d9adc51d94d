"""The models at work (D3.1 section 5): one depth image from the robot's camera, fitted with
the map's own models, gives the state of the home; and a view simulator that renders such an
observation from the map, with a structured-light sensor's noise.

`HomeScene` and `Renderer` (`tracking.scene`) pose and ray-cast the map's models;
`ViewSimulator` and `write_view` (`tracking.simulate_view`) render an observation folder
with its truth, the sensor's noise from `tracking.sensor_noise`.
"""

from tracking.observe import ObserveOptions, ObserveResult, observe, write_observed

__all__ = ["ObserveOptions", "ObserveResult", "observe", "write_observed"]
