from django.contrib.auth.decorators import login_not_required
from django.http import JsonResponse

from robot.state import link_status


@login_not_required
def healthz(request):
    """For load balancers and scripts: is the server up, is the robot link connected, and to which robot."""
    status = link_status()
    running = status.get("link_running", False)
    return JsonResponse({"ok": True, "connected": status["connected"], "link_running": running,
                         "robot_url": status.get("url") or ""})
