"""The HP-GL family: a plotter that acknowledges nothing, streamed by polling its free buffer
(:mod:`.plot`), its answers and sync points (:mod:`.link`), a lost buffer's stop found on the sheet
(:mod:`.refind`), the machine control (:mod:`.control`)."""
