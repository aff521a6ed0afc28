from django.db import migrations


class Migration(migrations.Migration):
    dependencies = [("history", "0005_drop_last_sampled_t")]

    operations = [migrations.DeleteModel(name="SeriesBucket")]
