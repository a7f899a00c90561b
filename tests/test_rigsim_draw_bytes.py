"""Every law set's random draws are the same bytes as when they were recorded (``rigsim.draw(s, laws)``, s < 60).

One table for every set: each law set's tests used to hold their own copy of the hashes of the sets before them
(test_rigsim_laws_v3 to _v7), the later copies a superset of the earlier ones. Each hash is the sha256 of
``json.dumps`` of the draws, per numpy SIMD level where the levels differ (:mod:`rig_bytes`); on a level without a
hash the draws are compared to their CPU-independent digest in ``data/rig_digests.json``.

Provenance (each entry at the commit before the set after it): ``all``, ``old``, ``new`` at c652758 (before
laws_v3) on the AVX512 (X86_V4) CI machine, the same bytes at c652758 and ac59446 on an AMD EPYC at X86_V3 (one
string: :data:`rig_bytes.BOTH`); ``v3`` at 934155e (before laws_v4) on the CI machine, whose X86_V3 draws differ by
an ulp (glibc's ``cosh`` in ``shape(0.01)``), recorded at ac59446 on the EPYC; ``v4`` at 0cfa3b3 (before laws_v5),
one string; ``v5`` at ac59446 (before laws_v6) on the EPYC at X86_V3, the same string found at X86_V4 at 8fb2b1d;
``v6`` at 8fb2b1d (before laws_v7) on an AMD EPYC at X86_V4; ``v7`` at 84b564b (before laws_v8) on an AMD EPYC at
X86_V4; ``v8`` at 2bacbab (its final draw ranges; branch lawsv8) on the same machine, found the same at 3eb51ca (before
laws_v9); ``v9`` at 436d469 (its final draw ranges; branch lawsv9) on an AMD EPYC at X86_V4, found the same at 230c926
(before laws_v10, with every other entry); ``v10`` at fc918d9 (its final draw ranges; branch lawsv10) on an AMD EPYC at
X86_V4, found the same at c0f56bb (before laws_v11, with every other entry); ``v11`` at 84050b3 (its final draw ranges;
branch lawsv11) on an AMD EPYC at X86_V4, found the same at a7b5b3d (before laws_v12, with every other entry); ``v12``
at 76d83cf (its final draw ranges; branch lawsv12) on an AMD EPYC at X86_V4, found the same at 89fea1f (branch lawsv13,
with every other entry); ``v13`` at 89fea1f (its final draw ranges; branch lawsv13) on an AMD EPYC at X86_V4, found
the same (by its CPU-independent digest, with every other entry) at 4eee964 on an AMD EPYC at X86_V3; ``v14`` at
4eee964 (its final draw ranges; branch lawsv14) on an AMD EPYC at X86_V3, found the same at 585200d (branch lawsv15,
with every other entry); ``v15`` at 585200d (its final draw ranges; branch lawsv15) on an AMD EPYC at X86_V3, found
the same at c887e4f (branch lawsv16, with every other entry); ``v16`` at c887e4f (its final draw ranges; branch
lawsv16) on an AMD EPYC at X86_V3, found the same at 78bac6e (branch lawsv17, with every other entry); ``v17`` at
78bac6e (its final draw ranges; branch lawsv17) on an AMD EPYC at X86_V3, found the same at branch lawsv18 (with every
other entry); ``v18`` at 08ae060 (its final draw ranges; branch lawsv18) on an AMD EPYC at X86_V3.
A new law set adds its entry here, recorded at the commit before it.
"""

from __future__ import annotations

import pytest
from rig_bytes import assert_same_draws

from maglev_ocp.rigsim import draw

DRAWS = {
    "all": "0aeaf2f8af4338fb6c56fc76e21a9bae3bc19f9791becea7e31e5a1259483cd3",
    "old": "d5c4373a10ddd66a63179bd65b54d882a96ee2e9ed2ce99535ca01e09369e106",
    "new": "4838bf4d375b30be6e7cc3ff50c3b834fde3b17f0cdf75854036a5cc3063aeff",
    "v3": {
        "X86_V4": "2a9d29a79062f28298cc896a5eebe8ddef9d83c6aa2a95a3cd1720eb24feb120",
        "X86_V3": "e59f7a240552924e6f961a94ea3394b5b9b6e320e1d180b4ed27b3aa888484d5",
    },
    "v4": "36a83350b82fa5b9f0a6d1272899ee9927ec84fec17f4409fcf62b66dfd06ace",
    "v5": {
        "X86_V3": "4caed51a1c99fec93ed1e97b357503faf505dc3e8a13fbd2b742cf84a5c9d080",
        "X86_V4": "4caed51a1c99fec93ed1e97b357503faf505dc3e8a13fbd2b742cf84a5c9d080",
    },
    "v6": {"X86_V4": "314b236562c025ae4051f4c1a9c172bde9e2c9fb2a052d331eb9b5422ca97456"},
    "v7": {"X86_V4": "e9a680938f8994a0f3a00175a4b11409cfb6054a9d915a7706383c5c7f5c59a3"},
    "v8": {"X86_V4": "67181848465d17f26f2b14f5398f13f0e94f55a35ec1f66c9319c6c044bfe8b5"},
    "v9": {"X86_V4": "ebe6f99a42afbb46bc81ff6495de0960425a69e8f5a642266d5ceb6b53e9753a"},
    "v10": {"X86_V4": "1975abd6959b5a9dacbfead513c2d347642d2408c30f4bcdb2ee34eadfa12d7c"},
    "v11": {"X86_V4": "83da8f13f5301b4d7f9e483f2a8674c4c5c553041cbeb12d80e382720b80615e"},
    "v12": {"X86_V4": "543c537156ff1c30e7f9b2884ce5a153b7b39c37f12b7e1052bb5ea6605a9c8c"},
    "v13": {"X86_V4": "78eb1e2529929eb7b294c8a5bb618b00c90cb9ff139f42df6b46980f961a137c"},
    "v14": {"X86_V3": "ba2ee8ccaf2283653b478f5b346eea63c70f4499d2baca0be05cb82fc8998552"},
    "v15": {"X86_V3": "772ae9ec5ed9e3e2a780f9fca3fd99ba608754eaa447d0fdde51d4836415821e"},
    "v16": {"X86_V3": "1a45f5ef4fe8cc470702e2a6855843bb5a227d086b3dcf53f152ea2df61fcbd8"},
    "v17": {"X86_V3": "50773220ef52f65405f1a8ca1da68380106c40ea7ad5b30912152fc0e7413bba"},
    "v18": {"X86_V3": "33021d9ee1313cdd8b6869ae0112135bd632175fd6f066ad1afd3c58b04ae08b"},
}


@pytest.mark.parametrize("laws", sorted(DRAWS))
def test_law_sets_draw_the_same_scenarios_as_when_recorded(laws):
    assert_same_draws(laws, [draw(s, laws=laws) for s in range(60)], DRAWS[laws])
