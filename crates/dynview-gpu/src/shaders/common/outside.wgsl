// A pixel index meaning "lands on no pixel" (off the image, or behind the camera).
const OUTSIDE: u32 = 0xffffffffu;
