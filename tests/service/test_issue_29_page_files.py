"""The page at ``/`` and every file it loads come from the package (no CDN, no build step)."""

from __future__ import annotations

import json
import re

from streamline_cam.service.page import WEB_DIR


def _module_imports(text: str) -> list[str]:
    return re.findall(r"""^\s*(?:import|export)\b[^;]*?\bfrom\s+["']([^"']+)["']""", text,
                      flags=re.M | re.S)


def test_the_page_and_everything_it_loads_are_served_from_the_package(service_client):
    with service_client(start_workers=False) as client:
        page = client.get("/")
        assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
        html = page.text
        imports = json.loads(re.search(r'<script type="importmap">(.*?)</script>', html,
                                       flags=re.S).group(1))["imports"]
        local = re.findall(r'(?:src|href)="([^"#]+)"', html)
        assert not [u for u in local if re.match(r"[a-z]+:", u) and u != "data:,"], local
        urls = [u for u in local if u.startswith("/web/")] + list(imports.values())
        modules = [u for u in urls if u.endswith(".js")]
        seen = set()
        while modules:  # follow the ES module graph from app.js through three.js
            url = modules.pop()
            if url in seen:
                continue
            seen.add(url)
            answer = client.get(url)
            assert answer.status_code == 200, url
            assert "javascript" in answer.headers["content-type"], (url, answer.headers)
            for target in _module_imports(answer.text):
                if target in imports:
                    modules.append(imports[target])
                else:
                    assert target.startswith("./"), (url, target)  # never a URL elsewhere
                    modules.append(url.rsplit("/", 1)[0] + target[1:])
        assert {"/web/app.js", "/web/preview.js", "/web/vendor/three/three.core.js",
                "/web/vendor/three/OrbitControls.js"} <= seen
        for url in urls:
            assert client.get(url).status_code == 200, url
        assert (WEB_DIR / "vendor" / "three" / "LICENSE").read_text().startswith(
            "The MIT License")
        assert client.get("/web/nope.js").status_code == 404
