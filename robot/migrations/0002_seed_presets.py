from django.db import migrations

from robot.interface import EMOTION_PRESETS

SOUND_CLIPS = [("hello_there", "Hello there"), ("goodbye", "Goodbye"), ("laugh", "Laugh"), ("horror", "Horror music")]
DOME_MODES = [("calm", "Calm"), ("happy", "Happy"), ("angry", "Angry"), ("rainbow", "Rainbow"), ("off", "Off")]


def seed(apps, schema_editor):
    EmotionPreset = apps.get_model("robot", "EmotionPreset")
    SoundClip = apps.get_model("robot", "SoundClip")
    DomeMode = apps.get_model("robot", "DomeMode")
    for name, (p, a, d) in EMOTION_PRESETS.items():
        EmotionPreset.objects.get_or_create(name=name, defaults={"pleasure": p, "arousal": a, "dominance": d})
    for name, label in SOUND_CLIPS:
        SoundClip.objects.get_or_create(name=name, defaults={"label": label})
    for name, label in DOME_MODES:
        DomeMode.objects.get_or_create(name=name, defaults={"label": label})


class Migration(migrations.Migration):
    dependencies = [("robot", "0001_initial")]
    operations = [migrations.RunPython(seed, migrations.RunPython.noop)]
