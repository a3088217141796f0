"""The neutral machine description: plotter profiles, the bed and where the sheet lies on it,
the pen model and the motion model. The writer, the estimate, the driver and the virtual plotter
all read a machine from here; nothing here knows a plan, G-code output or a serial port."""
