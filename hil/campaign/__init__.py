"""Campaigns (design.md §8): chunks of independent work with deterministic per-chunk seeds, run
on Dask distributed (an embedded LocalCluster by default, or an existing cluster), resumable
from the campaign folder, stopped cleanly by Ctrl-C. ``twin_ripple_map`` is the twin path of
ripple maps and sweeps on the same engine."""

from hil.campaign.engine import (CampaignInterrupted, CampaignResult, dask_client, run_campaign)
from hil.campaign.seeds import chunk_seed, chunk_sizes
from hil.campaign.twin import TwinSettings, twin_ripple_map, twin_ripple_pu

__all__ = ["CampaignInterrupted", "CampaignResult", "TwinSettings", "chunk_seed", "chunk_sizes",
           "dask_client", "run_campaign", "twin_ripple_map", "twin_ripple_pu"]
