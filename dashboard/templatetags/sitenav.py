"""Filters for the site's navigation."""

from __future__ import annotations

from django import template

register = template.Library()


@register.filter
def starts_with(value: str, prefix: str) -> bool:
    """``"/history/x/"|starts_with:"/history/"``: a section's pages, and no page that merely contains its path."""
    return bool(prefix) and str(value).startswith(str(prefix))
