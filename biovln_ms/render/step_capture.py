"""A step's camera pictures rendered while the task computes its measures, info and reward.

ManiSkill's ``step`` takes the sensors' pictures in ``get_obs``, after ``get_info``. Taking a picture only
submits the render (ManiSkill's ``capture_sensor_data`` is non-blocking); reading it back in
``Camera.get_obs`` waits for it. Submitting as soon as the step's scene is final lets the renderer (a GPU,
or lavapipe's threads on the CPU) work while the task's Python runs. Nothing between the submit and the
read-back moves the scene, so the frames are the same bytes (``tests/test_step_capture.py``).
"""

from __future__ import annotations

#: observation modes without camera pictures in ``get_obs`` (ManiSkill's ``BaseEnv.get_obs``)
NO_PICTURES = ("none", "state", "state_dict")


class CapturesDuringStep:
    """A ``BaseEnv`` mixin. The task calls :meth:`start_capture` once the step's scene is final (robot
    placed, people moved); the step's ``get_obs`` then reads those pictures instead of taking new ones.
    Only on the CPU physics backend, whose poses are current at that point (GPU physics fetches them after
    ``_after_control_step``). ``capture_during_step = False`` on an env takes the pictures in ``get_obs``."""

    capture_during_step = True
    _capture_pending = False

    def start_capture(self, prepare=None) -> None:
        """Submit the step's pictures; ``prepare()`` first places what the pictures show (the people)."""
        if not self.capture_during_step or self._obs_mode in NO_PICTURES or self.gpu_sim_enabled:
            return
        if prepare is not None:
            prepare()
        for obj in self._hidden_objects:  # as BaseEnv._get_obs_sensor_data does before its update
            obj.hide_visual()
        self.scene.update_render(update_sensors=True, update_human_render_cameras=False)
        super().capture_sensor_data()
        self._capture_pending = True

    def _get_obs_sensor_data(self, apply_texture_transforms: bool = True) -> dict:
        """ManiSkill's read-back; with this step's pictures pending, neither its render update (SAPIEN warns
        when a camera is updated between taking and reading a picture) nor its capture runs again."""
        if not self._capture_pending:
            return super()._get_obs_sensor_data(apply_texture_transforms)
        self.scene.update_render = _no_update
        try:
            return super()._get_obs_sensor_data(apply_texture_transforms)
        finally:
            del self.scene.update_render  # the scene's own method again
            self._capture_pending = False

    def capture_sensor_data(self) -> None:
        """ManiSkill's capture, unless this step's pictures are taken already."""
        if not self._capture_pending:
            super().capture_sensor_data()

    # a pending capture is this step's only: a step that raised before its read-back, a reset or a state
    # load leaves none behind
    def step(self, action):
        try:
            return super().step(action)
        finally:
            self._capture_pending = False

    def reset(self, *args, **kwargs):
        self._capture_pending = False
        return super().reset(*args, **kwargs)

    def set_state_dict(self, *args, **kwargs):
        self._capture_pending = False
        return super().set_state_dict(*args, **kwargs)


def _no_update(*args, **kwargs) -> None:
    """The render update of a step whose pictures are taken already."""
