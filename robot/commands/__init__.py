"""Commands operators send to the robot: modes, the command tool, motors.

Every command validates its input *before* anything is sent (rosbridge drops bad frames
silently), is a ``robot.commands.pipeline.Command`` run by the pipeline (role check + audit),
and talks to the robot only through ``robot.link.bus``.
"""
