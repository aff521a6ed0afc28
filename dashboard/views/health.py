from django.contrib.auth.decorators import login_not_required
from django.http import HttpRequest, JsonResponse
from django.views.decorators.cache import never_cache

from dashboard.health import health_report, may_see_details, public_report


@login_not_required
@never_cache  # the details differ by caller: no cache may hand staff's answer to anyone else
def healthz(request: HttpRequest) -> JsonResponse:
    """For load balancers and scripts: 503 naming what is down, else 200, and each check up or down;
    staff also get the robot's and the video server's addresses and the error texts."""
    report = health_report()
    if not report["ok"]:
        report["detail"] = "service unavailable: " + ", ".join(report["down"])
        report["code"] = "unavailable"
    return JsonResponse(report if may_see_details(request) else public_report(report),
                        status=200 if report["ok"] else 503)
