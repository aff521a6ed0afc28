"""Commands operators send to the robot: modes, the command tool, motors.

Every command validates its input *before* anything is sent (rosbridge drops bad frames
silently), runs through ``robot.commands.pipeline.arun_command`` (role check + audit), and talks
to the robot only through ``robot.link.bus``.
"""
