from django.contrib.auth.decorators import login_not_required
from django.http import HttpRequest, JsonResponse

from dashboard.health import health_report


@login_not_required
def healthz(request: HttpRequest) -> JsonResponse:
    """For load balancers and scripts: 503 naming what is down, else 200; and the robot link's state."""
    report = health_report()
    if not report["ok"]:
        report["detail"] = "service unavailable: " + ", ".join(report["down"])
        report["code"] = "unavailable"
    return JsonResponse(report, status=200 if report["ok"] else 503)
