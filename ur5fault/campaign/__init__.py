"""Fault campaigns: a YAML sweep expanded into runs (:mod:`.spec`), run in lockstep batches spread
over processes (:mod:`.execute`), stored atomically and resumably (:mod:`.store`), summarised
(:mod:`.summary`).  The campaign file's format is documented in :mod:`.spec`."""

from ..util.lock import FolderLockedError, Lock
from .execute import plan_batches, run_batch, run_campaign
from .result import CampaignResult
from .runs import CampaignRun
from .spec import Campaign, build_campaign, load_campaign
from .store import CampaignChangedError, consolidate
from .summary import acceptable_backlash, tcp_table
from .verify import status

__all__ = [
    "Campaign", "CampaignRun", "CampaignChangedError", "FolderLockedError", "CampaignResult", "Lock",
    "acceptable_backlash", "build_campaign", "consolidate", "load_campaign", "plan_batches", "run_batch",
    "run_campaign", "status", "tcp_table",
]
