"""``GET /jobs/{id}/plots/deviation``: the verified deviation map of a finished job."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image


def test_deviation_map_is_offered_and_drawn(service_client, finished_job):
    data_dir, job_id = finished_job
    with service_client(data_dir) as client:
        status = client.get(f"/jobs/{job_id}").json()
        assert status["links"]["plot:deviation"] == f"/jobs/{job_id}/plots/deviation"
        assert "deviation" in client.get("/machines").json()["plots"]
        png = client.get(status["links"]["plot:deviation"])
        assert png.status_code == 200 and png.headers["content-type"] == "image/png"
        image = np.asarray(Image.open(io.BytesIO(png.content)).convert("RGB"))
        assert image.shape[0] > 200 and image.shape[1] > 200
        assert len(np.unique(image.reshape(-1, 3), axis=0)) > 50  # a map, not a blank
        assert (data_dir / "jobs" / job_id / "plots" / "deviation.png").is_file()
