from django.conf import settings

from cyborg_site.roles import is_admin, is_operator, role_of


def roles(request):
    user = getattr(request, "user", None)
    return {
        "role": role_of(user),
        "can_command": is_operator(user),
        "can_admin": is_admin(user),
        "stale_after_s": settings.STALE_AFTER_S,
    }
