"""One alert system: raised where the robot link runs, shown on every page, kept with its history,
and delivered beyond the tab to those who ask (``robot.alerts.delivery``)."""
